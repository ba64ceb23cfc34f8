"""``python -m eval show RECORD``: a record's stroke drawn and animated (:data:`DESCRIPTION`):
the envs' render frame (:mod:`tandem_env.envs.render`) of the stroke, computed with the record's
own insect and model options (:func:`eval.studies.kinematics.record_history`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from agents.records import Record, RecordError
from agents.store import read_record
from tandem_env.io.files import atomic_path, output_directory

NAME = "show"
HELP = "draw and animate a record's stroke (PNG and GIF; MP4 where ffmpeg is installed)"
DESCRIPTION = """\
Draw the stroke of one harness record (a records/<key>.json file of `optimize` or `study`) as
the envs render it (wing-tip paths in side view, φ, θ and η of both wings over the cycle), and
animate it: each wing, its tip and a cursor on the histories move over one cycle. Writes into
--out (default: the show/ folder beside the record's records/ folder):
  <key>.png   the picture (200 dpi)
  <key>.gif   the animation (matplotlib's PillowWriter), or <key>.mp4 with --format mp4
              (matplotlib's FFMpegWriter; needs the ffmpeg program)"""
EPILOG = """\
example:
  python -m eval optimize --task level --speed 1.5 --budget 2000 --seeds 0 --out results/v1.5
  python -m eval show results/v1.5/records/<key>.json          # writes results/v1.5/show/"""

#: Animation formats and the matplotlib writer of each.
ANIMATION_FORMATS: dict[str, str] = {"gif": "pillow", "mp4": "ffmpeg"}
#: Frames per cycle and frames per second of the animation (defaults: a cycle in 3 s).
DEFAULT_FRAMES = 60
DEFAULT_FPS = 20


def default_out(record_path: Path) -> Path:
    """``DIR/show`` for a record at ``DIR/records/<key>.json``, else ``show`` beside it."""
    folder = record_path.parent
    return (folder.parent if folder.name == "records" else folder) / "show"


def show(
    record: Record, history: Any, out: Path, fmt: str = "gif", fps: int = DEFAULT_FPS
) -> tuple[Path, Path]:
    """Write ``out/<key>.png`` and the animation ``out/<key>.<fmt>`` (atomically); their paths."""
    from matplotlib import animation
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from eval.figures import DPI
    from tandem_env.envs.render import FRAME_DPI, FRAME_SIZE, WING_STYLE, Frame, draw, metrics_line

    subtitle = metrics_line(record.reward, record.metrics, record.objective_name)
    frame = Frame(title=record.label(), subtitle=subtitle, history=history)
    width, height = FRAME_SIZE
    figure = Figure(figsize=(width / FRAME_DPI, height / FRAME_DPI), dpi=FRAME_DPI)
    FigureCanvasAgg(figure)
    side, angle_axes = draw(figure, frame)
    moving = []  # per wing: its span line, its tip and a cursor per history panel
    for name in ("fore", "hind"):
        tip = getattr(history, name).tip_path
        colour = WING_STYLE[name]["color"]
        (span,) = side.plot([0.0, tip[0, 0]], [0.0, tip[0, 2]], "-", color=colour, lw=2.5)
        (head,) = side.plot([tip[0, 0]], [tip[0, 2]], "o", color=colour, ms=7, mec="k")
        cursors = [axis.axvline(0.0, color=colour, lw=1.0, ls=":") for axis in angle_axes]
        moving.append((tip, getattr(history, name).cycle_fraction, span, head, cursors))

    def place(k: int) -> None:
        for tip, cycle, span, head, cursors in moving:
            span.set_data([0.0, tip[k, 0]], [0.0, tip[k, 2]])
            head.set_data([tip[k, 0]], [tip[k, 2]])
            for cursor in cursors:
                cursor.set_xdata([cycle[k], cycle[k]])

    picture, movie = (out / f"{record.key}.{suffix}" for suffix in ("png", fmt))
    place(0)
    with atomic_path(picture) as tmp:
        figure.savefig(tmp, dpi=DPI)
    writer = animation.writers[ANIMATION_FORMATS[fmt]](fps=fps)
    with atomic_path(movie) as tmp, writer.saving(figure, str(tmp), dpi=FRAME_DPI):
        for k in range(len(history.fore.cycle_fraction)):
            place(k)
            writer.grab_frame()
    return picture, movie


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("record", metavar="RECORD", help="a record file (records/<key>.json)")
    text = "output folder (default: show/ beside records/)"
    parser.add_argument("--out", default=None, metavar="DIR", help=text)
    text = "animation format (default gif; mp4 needs ffmpeg)"
    parser.add_argument("--format", choices=tuple(ANIMATION_FORMATS), default="gif", help=text)
    for flag, default, metavar, text in (
        ("--frames", DEFAULT_FRAMES, "N", f"frames per cycle, 8 to 720 (default {DEFAULT_FRAMES})"),
        ("--fps", DEFAULT_FPS, None, f"frames per second (default {DEFAULT_FPS})"),
    ):
        parser.add_argument(flag, type=int, default=default, metavar=metavar, help=text)


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from matplotlib import animation

    from eval.studies.kinematics import record_history

    for flag, low, high in (("--frames", 8, 720), ("--fps", 1, 100)):
        if not low <= (value := getattr(args, flag[2:])) <= high:
            parser.error(f"{flag} {value}; allowed: an integer from {low} to {high}")
    if not animation.writers.is_available(ANIMATION_FORMATS[args.format]):
        parser.error(
            f"--format {args.format} needs the {ANIMATION_FORMATS[args.format]} program, which "
            "is not installed here; use --format gif (Pillow, installed with matplotlib)"
        )
    path = Path(args.record)  # each refusal one line naming it, before any drawing
    if not path.is_file():
        why = "not a file (give one records/<key>.json file)" if path.exists() else "no such file"
        parser.error(f"record {path}: {why}")
    try:
        record = read_record(path)
    except OSError as error:
        parser.error(f"record {path}: cannot read it ({error.strerror or error})")
    except RecordError as error:
        parser.error(str(error).splitlines()[0])
    out = Path(args.out) if args.out is not None else default_out(path)
    try:
        output_directory(out)
    except ValueError as error:
        parser.error(str(error))
    try:  # the model's own checks (a stroke outside Table 4, a parameter missing, bad keywords)
        history = record_history(record, args.frames)
    except KeyError as error:
        parser.error(f"record {path}: cannot show it: its stroke has no parameter {error}")
    except (TypeError, ValueError) as error:
        parser.error(f"record {path}: cannot show it: {str(error).splitlines()[0]}")
    picture, movie = show(record, history, out, args.format, args.fps)
    print(f"wrote {picture} and {movie}", file=sys.stderr)
    return 0

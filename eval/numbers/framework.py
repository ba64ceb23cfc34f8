"""The framework of ``python -m eval numbers``: where numbers live (``docs/numbers/<name>.json``
and the documents' marked regions), one :class:`Measurement`, the documented commands a
measurement runs (:func:`run_command`, :class:`Benchmark`), the machine a timing is read
against, and the helpers the measurements share."""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
NUMBERS_DIR = ROOT / "docs" / "numbers"
DOCUMENTS: tuple[Path, ...] = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))
REGION = re.compile(
    r"(<!-- numbers: (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /numbers -->)", re.DOTALL
)


def run_command(command: Sequence[str], environment: dict[str, str] | None = None) -> None:
    """Run a documented ``python ...`` command from the repository root with this interpreter
    (``environment``: variables set for it); a failure raises with the end of its stderr."""
    command = [sys.executable, *command[1:]] if command[0] == "python" else list(command)
    done = subprocess.run(
        command,
        cwd=ROOT,
        env={**os.environ, **(environment or {})},
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-2000:]}")


# --- benchmarks: documented commands run with --json (timings: shown, never compared) ---------
@dataclass(frozen=True)
class Benchmark:
    """A documented benchmark command; run with ``--json`` into a temporary file."""

    arguments: tuple[str, ...]
    """``python`` arguments: the script and its options."""
    environment: tuple[tuple[str, str], ...] = ()
    """Environment variables the documented command sets, as (name, value)."""

    @property
    def command(self) -> str:
        """The command as the documents show it."""
        return " ".join([*(f"{k}={v}" for k, v in self.environment), "python", *self.arguments])

    def run(self) -> dict[str, Any]:
        from tandem_env.io.files import read_json

        with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
            path = Path(out) / "numbers.json"
            run_command(["python", *self.arguments, "--json", str(path)], dict(self.environment))
            data = read_json(path)
        return {**data, "command": self.command}


def spaced(value: float, digits: int = 0) -> str:
    """``value`` with thin groups of thousands as the documents write them (12 000)."""
    return f"{value:,.{digits}f}".replace(",", " ")


RANDOM_STROKES = 1000
"""Random Table 4 strokes (uniform in the normalised box, seed 0) of the model's readings."""


def random_strokes(n: int = RANDOM_STROKES, seed: int = 0) -> Any:
    """(n, 28) physical strokes drawn uniformly in Table 4's box."""
    import numpy as np

    import tandem_env as te

    return te.normalised_to_physical(np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 28)))


@dataclass(frozen=True)
class Measurement:
    """One generated number set: ``measure`` runs it (its JSON, without the machine fields that
    :func:`main` adds), ``render`` turns the stored JSON into the region's Markdown."""

    name: str
    measure: Callable[[], dict[str, Any]]
    render: Callable[[dict[str, Any]], str]
    on_request: bool = False
    """Measured only when named in ``--only``: it collects a long study's outputs (run first)."""


def cpu_model() -> str:
    """The CPU's model name where the system tells it (Linux), else the architecture."""
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict[str, Any]:
    """Where and when a measurement ran (timings are read against this)."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "cpus": os.cpu_count(),
        "processor": platform.processor() or platform.machine(),
        "cpu_model": cpu_model(),
        "python": platform.python_version(),
        "load_average_1min": round(load[0], 2),
    }


def machine_line(data: dict[str, Any], name: str) -> str:
    """When, where and under what load measurement ``name`` ran, and how to rerun it."""
    before, after = data["machine_before"], data["machine_after"]
    cpu = before.get("cpu_model", before["processor"])
    return (
        f"Measured {before['date']} on {before['cpus']} CPUs ({cpu}, Python "
        f"{before['python']}), load average (1 min) {before['load_average_1min']} before and "
        f"{after['load_average_1min']} after; regenerate with `python -m eval numbers --only "
        f"{name}`."
    )


def json_path(name: str) -> Path:
    return NUMBERS_DIR / f"{name}.json"


def load(name: str) -> dict[str, Any]:
    return json.loads(json_path(name).read_text(encoding="utf-8"))


def save(name: str, data: dict[str, Any]) -> None:
    from tandem_env.io.files import atomic_path

    NUMBERS_DIR.mkdir(parents=True, exist_ok=True)
    with atomic_path(json_path(name)) as tmp:
        Path(tmp).write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", "utf-8")


def regions(text: str) -> Iterable[re.Match[str]]:
    return REGION.finditer(text)

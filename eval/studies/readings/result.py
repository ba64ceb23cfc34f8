"""One reading's analysed studies (:class:`ReadingResult`), readings.csv's headline numbers and
a reading's output folder (:mod:`eval.studies.readings`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from eval.studies.base import StudyOutput
from eval.studies.claims import Claim, VerdictCount
from eval.studies.paper_reading import Reading
from eval.studies.power import EXCESS_UNIT

#: The verdict counts of readings.csv and the readings tables, in their order
#: (:class:`~eval.studies.claims.VerdictCount` fields): column -> table title.
COUNTS = {
    k: k.replace("_", " ") for k in ("agree", "differ", "undecided", "not_identifiable", "no_data")
}

#: Headline numbers of readings.csv: column -> (claim id whose median it is, description).
HEADLINES: dict[str, tuple[str, str]] = {
    "eta_max_pct": ("S7", "highest median level-flight efficiency over speeds [%]"),
    "Fv_50": ("P1a", f"median F̄_v at 50 W/kg {EXCESS_UNIT}"),
    "Fv_90": ("P1b", f"median F̄_v at 90 W/kg {EXCESS_UNIT}"),
    "Fh_50": ("P2a", f"median F̄_h at 50 W/kg {EXCESS_UNIT}"),
    "Fh_90": ("P2b", f"median F̄_h at 90 W/kg {EXCESS_UNIT}"),
    "Fa_50": ("P6a", f"median F̄_a at 50 W/kg {EXCESS_UNIT}"),
    "Fa_90": ("P6b", f"median F̄_a at 90 W/kg {EXCESS_UNIT}"),
}


@dataclass(frozen=True)
class ReadingResult:
    """One reading's studies, analysed."""

    reading: Reading
    outputs: tuple[StudyOutput, ...]

    @property
    def claims(self) -> list[Claim]:
        return [c for o in self.outputs for c in o.claims]

    @property
    def counts(self) -> VerdictCount:
        """Its verdict counts on the median."""
        return VerdictCount.of(self.claims)

    @property
    def agree(self) -> int:
        return self.counts.agree

    @property
    def differ(self) -> int:
        return self.counts.differ

    def verdicts(self) -> dict[str, str]:
        return {c.id: c.verdict for c in self.claims}

    def headline(self) -> dict[str, float]:
        """The :data:`HEADLINES` numbers: the medians of those claims (NaN where absent)."""
        by_id = {c.id: c for c in self.claims}
        return {
            k: by_id[cid].median if cid in by_id else math.nan for k, (cid, _) in HEADLINES.items()
        }


def reading_dir(out_dir: Path, reading: Reading) -> Path:
    """The folder of one reading's study outputs, ``DIR/<name>``."""
    return out_dir / reading.name

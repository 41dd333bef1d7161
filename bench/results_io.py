"""What every benchmark shares: the machine description and the JSON result file."""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
from pathlib import Path

import numpy as np


def machine_meta(**extra: object) -> dict[str, object]:
    """Date, CPU count, architecture and library versions of this run."""
    return {"date": dt.date.today().isoformat(), "machine": platform.machine(),
            "cpus": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, **extra}


def write_results(out: Path, suite: str, meta: dict[str, object], results: list) -> Path:
    """Write ``{"meta", "results"}`` to ``out/<suite>-<date>.json``; returns the path."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{suite}-{meta['date']}.json"
    path.write_text(json.dumps({"meta": meta, "results": results}, indent=2) + "\n")
    print(f"wrote {path}")
    return path

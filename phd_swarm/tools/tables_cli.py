"""The command line a per-paper tables tool shares: sweep directories in, files out.

``python -m phd_swarm.tools.<paper>_tables DIR [DIR ...] [--out OUT]`` reads each sweep
directory with the tool's ``build``, writes what its ``write`` makes into ``OUT`` (default:
the first ``DIR``) and prints its Markdown; a directory that cannot be read is an error
naming it (exit code 2).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from phd_swarm.tools.sung_tables import SungTablesError


def run(argv: Sequence[str] | None, name: str, description: str,
        build: Callable[[Path], Any], write: Callable[[list[Any], Path], str]) -> int:
    """Parse ``argv``, build every directory's table, write them; the exit code.

    Parameters
    ----------
    argv : sequence of str or None
        Arguments without the program name (None: ``sys.argv[1:]``).
    name : str
        The tool's module name (``shirsat_tables``), for usage and errors.
    description : str
        The tool's one-line description.
    build : callable
        ``build(directory) -> table``; raises on a directory it cannot read.
    write : callable
        ``write(tables, out) -> markdown``: writes the tool's files into ``out``.
    """
    p = argparse.ArgumentParser(prog=f"python -m phd_swarm.tools.{name}",
                                description=description)
    p.add_argument("dirs", nargs="+", type=Path, help="sweep directories")
    p.add_argument("--out", type=Path, help="output directory (default: the first DIR)")
    args = p.parse_args(argv)
    try:
        tables = [build(d) for d in args.dirs]
    except (SungTablesError, OSError, KeyError, ValueError) as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return 2
    out = args.out or args.dirs[0]
    out.mkdir(parents=True, exist_ok=True)
    print(write(tables, out))
    print(f"wrote the {name} files into {out}")
    return 0

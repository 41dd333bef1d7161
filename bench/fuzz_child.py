"""One fuzz target under atheris (libFuzzer), for ``bench/fuzz.py``.

``python bench/fuzz_child.py TARGET [libFuzzer options] CORPUS_DIR``: imports phd_swarm
instrumented for coverage, then feeds libFuzzer's inputs to
:func:`phd_swarm.tools.fuzz_targets.exercise`. A :class:`~phd_swarm.tools.fuzz_targets.Finding`
(an input the target does not survive) is an uncaught exception: libFuzzer writes the input
to its artifact prefix and exits non-zero; so does an input slower than ``-timeout``.
"""

from __future__ import annotations

import sys

import atheris

with atheris.instrument_imports(include=["phd_swarm"]):
    from phd_swarm.tools.fuzz_targets import exercise, targets


def main() -> None:
    """Fuzz the target named by the first argument (libFuzzer's options follow)."""
    name, argv = sys.argv[1], [sys.argv[0], *sys.argv[2:]]
    target = targets()[name]
    target.seeds()  # built once, before the clock starts

    def one_input(data: bytes) -> None:
        exercise(target, data)

    atheris.Setup(argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()

"""What the run's key costs (issue 40): sealing and checking an envelope, per message.

Run with ``scripts/bench.sh auth [--quick]``. For inbox envelopes of 100 B, 1 kB, 10 kB and
100 kB (a state; a cell; a transfer of bins; a large hand-over) it times
:func:`phd_swarm.nodes.inbox.pack_cdr` and :func:`~phd_swarm.nodes.inbox.unpack_cdr` with
and without a key, and the measurement set of 10 measurements
(:func:`phd_swarm.nodes.convert.encode_scan` / ``decode_scan``), the median of repeated
batches, in microseconds per message, and the difference the key makes. Writes
``bench/results/auth-<date>.json``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from results_io import machine_meta, write_results

from phd_swarm.nodes import auth, convert, inbox

KEY = bytes(range(auth.KEY_BYTES))


def per_call_us(fn: Callable[[], object], batch: int, repeats: int) -> float:
    """Median over ``repeats`` batches of ``batch`` calls of ``fn``, per call [us]."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(batch):
            fn()
        times.append((time.perf_counter() - t0) / batch * 1e6)
    return statistics.median(times)


def main() -> None:
    """Time each case with and without the key; print and write the figures."""
    p = argparse.ArgumentParser(prog="scripts/bench.sh auth")
    p.add_argument("--quick", action="store_true", help="few repeats")
    p.add_argument("--out", type=Path, default=Path(__file__).with_name("results"))
    opts = p.parse_args()
    batch, repeats = (200, 3) if opts.quick else (2000, 7)
    rows = []
    kinds = {"state", "cell", "particles"}
    for size in (100, 1_000, 10_000, 100_000):
        pieces = [("particles", b"\x00\x01\x00\x00" + bytes(size - 4))]
        for keyed in (False, True):
            key = KEY if keyed else None
            data = inbox.pack_cdr(1, pieces, key)
            rows.append({"message": f"envelope {size} B", "keyed": keyed,
                         "pack_us": per_call_us(lambda k=key, p=pieces: inbox.pack_cdr(1, p, k),
                                                batch, repeats),
                         "unpack_us": per_call_us(lambda d=data, k=key:
                                                  inbox.unpack_cdr(d, kinds, k),
                                                  batch, repeats)})
    z = np.random.default_rng(0).uniform(0, 100, (10, 2))
    sensor = np.array([50.0, 50.0])
    for keyed in (False, True):
        key = KEY if keyed else None
        data = convert.encode_scan(3, 0.5, "map", 2, sensor, z, key)
        rows.append({"message": "measurement set, 10 measurements", "keyed": keyed,
                     "pack_us": per_call_us(lambda k=key: convert.encode_scan(
                         3, 0.5, "map", 2, sensor, z, k), batch, repeats),
                     "unpack_us": per_call_us(lambda d=data, k=key:
                                              convert.decode_scan(d, 100, k),
                                              batch, repeats)})
    print(f"{'message':<36}{'keyed':>6}{'pack us':>10}{'unpack us':>11}{'key adds us':>13}")
    for plain, keyed in zip(rows[::2], rows[1::2], strict=True):
        for r in (plain, keyed):
            r["pack_us"], r["unpack_us"] = round(r["pack_us"], 2), round(r["unpack_us"], 2)
        added = keyed["pack_us"] + keyed["unpack_us"] - plain["pack_us"] - plain["unpack_us"]
        keyed["key_adds_us"] = round(added, 2)
        for r in (plain, keyed):
            print(f"{r['message']:<36}{str(r['keyed']):>6}{r['pack_us']:>10}"
                  f"{r['unpack_us']:>11}{r.get('key_adds_us', ''):>13}")
    write_results(opts.out, "auth", machine_meta(batch=batch, repeats=repeats), rows)


if __name__ == "__main__":
    main()

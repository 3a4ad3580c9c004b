"""The Python module's figures: a one-line run against the same run in Rust, reading a 256³
scalar cache into NumPy, and importing the module.

    python bench/bench.py [--rust-bin PATH]

--rust-bin names the `one_line` example (`cargo build --release --example one_line`, in
python/), run just before the Python figure so both see the same machine load.
"""

import argparse
import subprocess
import sys
import time

import felt

RUNS = 200


def one_line_ms():
    session = felt.Session()
    script = "float a = 1.0 + 2.0;"
    for _ in range(10):
        session.run(script)
    start = time.perf_counter()
    for _ in range(RUNS):
        session.run(script)
    return (time.perf_counter() - start) / RUNS * 1e3


def cache_read_gb_per_s():
    session = felt.Session()
    session.run(
        "domain d((0,0,0), (1,1,1), (0,0,0), 0.00390625);\n"
        "vectorfield p = identity();\nscalarcache c(d);\ncachewrite(c, p.x + p.y * p.z);\ncachefill(c);\n"
    )
    session.get("c")  # warm-up: the first read pages the output buffer in
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        grid = session.get("c")
        best = min(best, time.perf_counter() - start)
    assert grid.values.shape == (256, 256, 256)
    return grid.values.nbytes / best / 1e9


def import_seconds():
    code = "import time; t = time.perf_counter(); import felt; print(time.perf_counter() - t)"
    runs = [float(subprocess.check_output([sys.executable, "-c", code])) for _ in range(5)]
    return min(runs)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--rust-bin", default=None)
    args = parser.parse_args()
    rust_ms = None
    if args.rust_bin:
        line = subprocess.check_output([args.rust_bin], text=True).strip()
        print(line)
        rust_ms = float(line.split(":")[1].split()[0])
    python_ms = one_line_ms()
    print(f"python one-line run: {python_ms:.3f} ms")
    if rust_ms is not None:
        print(f"python - rust: {python_ms - rust_ms:+.3f} ms (target: within 1 ms)")
    print(f"256^3 scalar cache into NumPy: {cache_read_gb_per_s():.2f} GB/s (target: >= 1)")
    print(f"import felt: {import_seconds() * 1e3:.1f} ms (target: < 200)")


if __name__ == "__main__":
    main()

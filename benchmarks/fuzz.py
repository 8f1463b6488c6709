"""The long run of servolab's fuzzers (issue 45): every test marked ``fuzz`` (a hypothesis
fuzzer of a parser of outside input: CDR of every robot message type, rmw_zenoh attachments,
MCAP records, launch, parameter and motion files, the view's messages, Dynamixel status
packets), run ``--scale`` times as many examples as ``make test`` runs, with hypothesis's
statistics. It prints, per fuzzer, the inputs tried and whether it failed, then the totals
beside the suite's own short run's figure (the anchor: ``--scale 1``, measured first in the
same run), so that a machine's speed does not hide a fuzzer that stopped trying.

Run: ``.venv/bin/python benchmarks/fuzz.py [--scale N] [--quick] [--only TEXT] [--json PATH]``
(``--quick``: scale 2, the smoke test's).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: hypothesis's statistics: "- during generate phase (0.52 seconds):" then, indented,
#: "- 60 passing, 0 failing, and 3 invalid test cases" (hypothesis 6.100 and later)
_TEST = re.compile(r"^(\S+::\S+):\s*$")
_EXAMPLES = re.compile(r"(\d+) passing, (\d+) failing, and (\d+) invalid")


def run(scale: int, only: str = "") -> tuple[dict[str, dict[str, int]], float, int]:
    """Every fuzzer at ``scale`` (of the test files whose path holds ``only``): per test, the
    inputs tried and failing; the seconds taken; pytest's exit status."""
    env = {**os.environ, "SERVOLAB_FUZZ_SCALE": str(scale)}
    files = sorted(str(path) for path in (ROOT / "tests").rglob("test_*.py")
                   if only in str(path) and "mark.fuzz" in path.read_text())
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-m", "fuzz", "-p", "no:cacheprovider",
         "--hypothesis-show-statistics", *files],
        cwd=ROOT, env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - started
    found: dict[str, dict[str, int]] = {}
    test = None
    for line in done.stdout.splitlines():
        if (named := _TEST.match(line)) is not None:
            test = named[1]
            found.setdefault(test, {"tried": 0, "failing": 0})
        elif test is not None and (counts := _EXAMPLES.search(line)) is not None:
            passing, failing, invalid = map(int, counts.groups())
            found[test]["tried"] += passing + failing + invalid
            found[test]["failing"] += failing
    if done.returncode not in (0, 5) and not found:
        print(done.stdout[-3000:], done.stderr[-3000:], file=sys.stderr)
    return found, seconds, done.returncode


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scale", type=int, default=50,
                        help="times the suite's examples (default 50)")
    parser.add_argument("--quick", action="store_true", help="scale 2 (the smoke test's)")
    parser.add_argument("--only", default="", metavar="TEXT",
                        help="only the test files whose path holds TEXT")
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    scale = 2 if args.quick else args.scale
    anchor, anchor_s, _ = run(1, args.only)
    found, seconds, status = run(scale, args.only)
    print(f"{'fuzzer':78s} {'inputs':>8s} {'failing':>8s}")
    for test, counts in sorted(found.items()):
        print(f"{test[-78:]:78s} {counts['tried']:8d} {counts['failing']:8d}")
    tried = sum(c["tried"] for c in found.values())
    failing = sum(c["failing"] for c in found.values())
    base = sum(c["tried"] for c in anchor.values())
    print(f"{len(found)} fuzzers, {tried} inputs in {seconds:.1f} s at scale {scale}; "
          f"{failing} failing; the suite's own run: {base} inputs in {anchor_s:.1f} s "
          f"(x{tried / max(base, 1):.1f} the inputs)")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "scale": scale, "fuzzers": found, "inputs": tried, "failing": failing,
            "seconds": seconds, "suite_inputs": base, "suite_seconds": anchor_s}, indent=2))
    return 0 if status in (0, 5) and failing == 0 else 1


if __name__ == "__main__":
    sys.exit(main())

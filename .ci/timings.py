"""Time the README's two commands on a fresh clone, set-up included, and say where they ran.

    python .ci/timings.py --out docs/timings.md    (or: make timings)

Clones this checkout's HEAD into a temporary folder, runs ``make test`` and then ``make demo``
there (each creates and fills its venv from the lock first), and prints a Markdown table with
the wall time of each, pytest's closing line, the machine's cores and processor, and the load
average before and after. ``--out`` also writes the table to a file and puts the two times into
the sentence of the README and of ``docs/getting-started.md`` that quotes them
(``tests/test_installs.py`` checks that they agree).
A maintainer's tool beside CI's script, not an installed command: it needs git and make.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # .ci/ is one below the checkout
COMMANDS = ("make test", "make demo")
QUOTING_PAGES = ("README.md", "docs/getting-started.md")
DURATION = r"(?:\d+ min )?\d+ s"  # as minutes() writes it: "5 min 21 s", "53 s"
QUOTE = re.compile(rf"`make demo` took {DURATION} and `make test` {DURATION}")
PYTEST_SUMMARY = re.compile(r"^=* ?(\d+ passed.*?)(?: in [\d.]+s.*)?=*$", re.M)


def processor() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown processor"


def minutes(seconds: float) -> str:
    m, s = divmod(round(seconds), 60)
    return f"{m} min {s} s" if m else f"{s} s"


def run(command: str, clone: Path) -> tuple[float, str, str]:
    """Wall time, the load average before → after, and pytest's closing line (if any)."""
    before = os.getloadavg()[0]
    start = time.monotonic()
    done = subprocess.run(command.split(), cwd=clone, capture_output=True, text=True)
    took = time.monotonic() - start
    if done.returncode != 0:
        sys.exit(f"`{command}` failed (exit {done.returncode}):\n{done.stdout[-3000:]}")
    summary = PYTEST_SUMMARY.findall(done.stdout)
    return took, f"{before:.1f} → {os.getloadavg()[0]:.1f}", summary[-1] if summary else ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="also write the table to this Markdown file")
    args = parser.parse_args()
    head = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
        check=True,
    ).stdout.strip()  # fmt: skip
    rows, times = [], {}
    with tempfile.TemporaryDirectory() as folder:
        clone = Path(folder) / "visuomotor"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        for command in COMMANDS:
            print(f"running `{command}` in {clone} ...", flush=True)
            took, load, summary = run(command, clone)
            times[command] = minutes(took)
            rows.append(f"| `{command}` | {times[command]} | {load} | {summary or '-'} |")
    table = "\n".join(
        [
            f"Measured by `make timings` on {datetime.date.today()} at commit {head}",
            f"(a fresh clone, set-up included) on {os.cpu_count()} cores ({processor()}), no GPU.",
            "",
            "| command | wall time | load average (1 min) before → after | tests |",
            "|---|---|---|---|",
            *rows,
        ]
    )
    print(table)
    if args.out:
        args.out.write_text(f"# Timings of the two front-door commands\n\n{table}\n")
        quote = f"`make demo` took {times['make demo']} and `make test` {times['make test']}"
        for page in QUOTING_PAGES:
            path = ROOT / page
            text, found = QUOTE.subn(quote, path.read_text())
            if found != 1:
                sys.exit(f"{page}: expected one sentence like {QUOTE.pattern!r}, found {found}")
            path.write_text(text)


if __name__ == "__main__":
    main()

"""What the section-wise benchmarks (``axisym_deep_furrow.py``, ``constriction.py``) share: a header
naming the script, the date, the machine and the commit, then each chosen section with its time."""

from __future__ import annotations

import os
import platform
import subprocess
import time


def run_sections(script: str, sections: dict, chosen, smoke: bool) -> None:
    """Print the header of ``script`` (an HTML comment), then run ``chosen`` sections of
    ``sections`` (all when empty) in order, each followed by a comment with its wall time."""
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            cwd=os.path.dirname(os.path.abspath(__file__)),
        ).stdout.strip()
    except OSError:
        commit = "?"
    print(
        f"<!-- {script}{' --smoke' if smoke else ''} on {time.strftime('%Y-%m-%d %H:%M %Z')}, "
        f"{platform.node()} ({platform.machine()}, {os.cpu_count()} cores), commit {commit} -->\n"
    )
    for name in chosen or sections:
        t0 = time.perf_counter()
        sections[name]()
        print(f"<!-- section {name}: {time.perf_counter() - t0:.0f} s -->\n", flush=True)

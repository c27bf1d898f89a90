"""Write one section of bench/BENCHMARKS.md, leaving the other sections as they are.

Each benchmark script owns a section delimited by ``<!-- BEGIN name -->`` and
``<!-- END name -->`` and rewrites only that, with the date and the machine.
"""
import datetime
import os
import platform
import re

HERE = os.path.dirname(os.path.abspath(__file__))
REPORT = os.path.join(HERE, "BENCHMARKS.md")
HEADER = ("# serial_dynamics benchmarks\n\nRegenerate everything with `bash bench/run_all.sh` "
          "(or one script at a time, as each section says). Times are wall-clock on the "
          "machine named in each section; ratios are ours / peer's (lower is better).\n")


def machine() -> str:
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()}"


def stamp() -> str:
    return f"_Measured {datetime.date.today().isoformat()} on {machine()}._\n"


def write_section(name: str, body: str) -> None:
    text = open(REPORT).read() if os.path.exists(REPORT) else HEADER
    block = f"<!-- BEGIN {name} -->\n{body.rstrip()}\n<!-- END {name} -->"
    pattern = re.compile(rf"<!-- BEGIN {re.escape(name)} -->.*?<!-- END {re.escape(name)} -->", re.S)
    text = pattern.sub(lambda _: block, text) if pattern.search(text) else text.rstrip() + "\n\n" + block + "\n"
    with open(REPORT, "w") as fh:
        fh.write(text)
    print(f"wrote section {name!r} of {REPORT}")

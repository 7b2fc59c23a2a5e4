"""Regenerate RESULTS.md: file -> format -> read as its library reads it? -> units -> `vrelab analyze`.

    PYTHONPATH=src python tests/data/thirdparty/make_results.py > tests/data/thirdparty/RESULTS.md

"Read as the library reads it" is tests/test_thirdparty_corpus.py's verdict; analyze runs on a
plausible DUT (the first channel the file states in an acceleration unit, else the first), with
--fs 1000 where the file states no rate and --dut-units lsb --dut-sensitivity 1000 for counts.
Most files are not shaker tests: a refusal such as "no vibration level found" is their right answer.
"""

import subprocess
import sys
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # tests/
import test_thirdparty_corpus as T  # noqa: E402

warnings.simplefilter("ignore")
print("| file | format | read as the library reads it? | units stated | `vrelab analyze` options -> outcome |")
print("| --- | --- | --- | --- | --- |")
for e in T.MANIFEST:
    path = T.DATA / e["file"]
    problems = T.check_file(e)
    try:
        lib = T.LIBRARY[e["format"]](path)
    except Exception:
        lib = {}
    accel = [n for n, c in lib.items() if c.unit in T.ACCEL_PER_G]
    dut = (accel or list(lib) or ["0"])[0]
    ch = lib.get(dut)
    opts = ["--dut", dut]
    if ch is not None and ch.rate_hz is None:
        opts += ["--fs", "1000"]
    if ch is not None and ch.integer and ch.unit in T.NO_UNIT:
        opts += ["--dut-units", "lsb", "--dut-sensitivity", "1000"]
    r = subprocess.run([sys.executable, "-m", "vrelab", "analyze", str(path), *opts], capture_output=True, text=True)
    said = (r.stderr.strip().splitlines() or [""])[-1] if r.returncode else " ".join(r.stdout.split())[:160]
    said = said.replace("vrelab: error: ", "").replace(f"{path.name}: ", "")
    verdict = ("refused, rightly: " + e["why_refused"] if "expected" in e and not problems else
               "yes" if not problems else f"NO: {problems[0]}" + (f" (+{len(problems) - 1} more)" if len(problems) > 1 else ""))
    units = ", ".join(sorted({c.unit or "-" for c in lib.values()})) or "-"
    print(f"| {e['file']} | {e['format']} | {verdict.replace('|', '/')} | {units} | `{' '.join(opts)}` -> exit {r.returncode}: "
          f"{said.replace('|', '/')} |")

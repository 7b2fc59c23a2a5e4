"""Install headless Chromium for the report's browser test where it is missing (Debian).

Run by `make test` before pytest. Without root or apt the browser test will fail loudly,
not skip: the report must be checked in a real browser.

apt waits for the dpkg lock (another apt or unattended-upgrades may hold it) up to
LOCK_TIMEOUT_S, saying so first; past that it fails with apt's own message, not silently.
"""

import os
import shutil
import subprocess
import sys

LOCK_TIMEOUT_S = 600

if shutil.which("chromium") or shutil.which("chromium-browser"):
    sys.exit(0)
if os.geteuid() != 0 or not shutil.which("apt-get"):
    print("setup_browser: chromium missing and cannot install it (need root and apt-get)", file=sys.stderr)
    sys.exit(0)
print(
    "setup_browser: installing Debian's chromium package (headless Chromium and its libraries, "
    f"a few hundred MB) for the report's browser tests; waiting up to {LOCK_TIMEOUT_S} s for the "
    "dpkg lock if another package manager holds it ...",
    flush=True,
)
env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
lock = [f"-oDPkg::Lock::Timeout={LOCK_TIMEOUT_S}"]
for step, cmd in (
    ("apt-get update", ["apt-get", *lock, "update", "-qq"]),
    ("apt-get install chromium", ["apt-get", *lock, "install", "-y", "-qq", "chromium"]),
):
    done = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        print(f"setup_browser: {step} failed (exit {done.returncode}): {last}", file=sys.stderr)
        sys.exit(done.returncode)
print("setup_browser: chromium installed", flush=True)

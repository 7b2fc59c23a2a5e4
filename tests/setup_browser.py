"""Install headless Chromium for the report's browser test where it is missing (Debian).

Run by `make test` before pytest. Without root or apt the browser test will fail loudly,
not skip: the report must be checked in a real browser.
"""

import os
import shutil
import subprocess
import sys

if shutil.which("chromium") or shutil.which("chromium-browser"):
    sys.exit(0)
if os.geteuid() != 0 or not shutil.which("apt-get"):
    print("setup_browser: chromium missing and cannot install it (need root and apt-get)", file=sys.stderr)
    sys.exit(0)
print("setup_browser: installing Debian's chromium for the report test ...", flush=True)
env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
subprocess.run(["apt-get", "update", "-qq"], check=True, env=env, stdout=subprocess.DEVNULL)
subprocess.run(["apt-get", "install", "-y", "-qq", "chromium"], check=True, env=env, stdout=subprocess.DEVNULL)

#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Generate rmdd's LCM types into a package directory: gen_types.py OUT [--with-sources].

lcm-gen writes one module per type plus an __init__.py that imports them;
here that __init__.py becomes rmd/_types.py, which the package's own
rmd/__init__.py imports (with the client).  --with-sources also copies the
hand-written modules (rmd/*.py beside this file), which makes OUT/rmd the
whole package: `make lcm-python` does that for PYTHONPATH=build/python.
setup.py calls generate() while `pip install ./python` builds.

lcm-gen is $LCM_GEN, else `lcm-gen` on PATH (Debian's liblcm-bin 1.3.1 and
PyPI's lcm 1.5.3 write the same Python).  The .lcm files are lcm_types/
beside this file (a link to the checkout's), else ../lcm_types.
"""

import glob
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def lcm_files():
    for d in (os.path.join(HERE, "lcm_types"), os.path.join(HERE, "..", "lcm_types")):
        files = sorted(glob.glob(os.path.join(d, "*.lcm")))
        if files:
            return files
    raise SystemExit(f"gen_types.py: no lcm_types/*.lcm beside {HERE} or above it")


def generate(out_dir, with_sources=False):
    """Write out_dir/rmd/<type>.py and out_dir/rmd/_types.py (and the sources)."""
    lcm_gen = os.environ.get("LCM_GEN") or "lcm-gen"
    pkg = os.path.join(out_dir, "rmd")
    os.makedirs(pkg, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            subprocess.run([lcm_gen, "-p", "--ppath", tmp] + lcm_files(), check=True)
        except FileNotFoundError:
            raise SystemExit(f"gen_types.py: {lcm_gen} not found: the rmd types are generated "
                             "by lcm-gen (Debian: apt install liblcm-bin; or set LCM_GEN)")
        except subprocess.CalledProcessError as e:
            raise SystemExit(f"gen_types.py: {lcm_gen} failed (exit {e.returncode})")
        for path in glob.glob(os.path.join(tmp, "rmd", "*.py")):
            name = os.path.basename(path)
            shutil.copyfile(path, os.path.join(pkg, "_types.py" if name == "__init__.py"
                                               else name))
    if with_sources:
        for path in glob.glob(os.path.join(HERE, "rmd", "*.py")):
            shutil.copyfile(path, os.path.join(pkg, os.path.basename(path)))
    return pkg


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--with-sources"]
    if len(args) != 1:
        raise SystemExit("usage: gen_types.py OUT_DIR [--with-sources]")
    generate(args[0], "--with-sources" in sys.argv[1:])

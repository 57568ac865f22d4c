# SPDX-License-Identifier: MIT
# The metadata is in pyproject.toml, but for the version: rmdd's
# (../tools/version), so the package, the .deb and `rmdd --version` agree.
# This also adds the generated LCM types (gen_types.py: lcm-gen on
# ../lcm_types/*.lcm) to what build_py copies.
import os
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen_types  # noqa: E402


class build_py_with_types(build_py):
    def run(self):
        super().run()
        if not self.dry_run:
            gen_types.generate(self.build_lib)


def rmd_version():
    """rmdd's version (../tools/version), or $RMD_VERSION when it is set."""
    if os.environ.get("RMD_VERSION"):
        return os.environ["RMD_VERSION"]
    here = os.path.dirname(os.path.abspath(__file__))
    return subprocess.check_output([os.path.join(here, "..", "tools", "version")], text=True).strip()


setup(version=rmd_version(), cmdclass={"build_py": build_py_with_types})

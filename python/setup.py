# SPDX-License-Identifier: MIT
# The metadata is in pyproject.toml, but for the version: rmdd's
# (../tools/version), so the package, the .deb and `rmdd --version` agree.
# This also adds the generated LCM types (gen_types.py: lcm-gen on
# ../lcm_types/*.lcm) to what build_py copies.
import os
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


setup(version=gen_types.rmd_version(), cmdclass={"build_py": build_py_with_types})

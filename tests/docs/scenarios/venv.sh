# where: host
# home: empty
# net: host (pip fetches from PyPI)
# README.md, examples/README.md, python/README.md, docs/lcm.md: the Python
# package into a venv, as Debian 12 wants it (PEP 668).
python3 -m venv ~/rmd-venv
~/rmd-venv/bin/pip install ./python
~/rmd-venv/bin/python3 -c 'import rmd, lcm; print("rmd", rmd.__file__); rmd.Client'

# SPDX-License-Identifier: MIT
"""The binding as an installed package: `pip install --no-build-isolation --no-index` works
offline (Debian's python3-setuptools + python3-wheel), and the installed package finds the
library of its own installation prefix with no environment variable."""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

import lidarflow

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(HERE)  # bindings/python


class Packaging(unittest.TestCase):
    def test_version_matches_the_library(self):
        with open(os.path.join(SOURCE, "pyproject.toml")) as f:
            m = re.search(r'^version = "([^"]+)"', f.read(), re.M)
        self.assertIsNotNone(m)
        self.assertEqual(m.group(1), lidarflow.__version__)

    def test_offline_prefix_install_finds_its_library(self):
        built = lidarflow._lib.lib._name  # the library this test run uses
        with tempfile.TemporaryDirectory() as tmp:
            src = os.path.join(tmp, "src")  # setuptools writes build/ and *.egg-info next to it
            shutil.copytree(SOURCE, src, ignore=shutil.ignore_patterns("tests", "tests_lcm", "tests_dask", "__pycache__",
                                                                       "build", "*.egg-info"))
            prefix = os.path.join(tmp, "prefix")
            p = subprocess.run([sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-index",
                                "--no-deps", "--prefix", prefix, "."], cwd=src, capture_output=True, text=True)
            self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
            inits = [os.path.join(d, "__init__.py") for d, _, files in os.walk(prefix)
                     if os.path.basename(d) == "lidarflow" and "__init__.py" in files]
            self.assertEqual(len(inits), 1, inits)
            site = os.path.dirname(os.path.dirname(inits[0]))
            libdir = os.path.dirname(os.path.dirname(site))  # PREFIX/lib (Debian pip: PREFIX/local/lib)
            self.assertEqual(os.path.basename(libdir), "lib")
            installed = os.path.join(libdir, "liblidarflow.so.0")
            shutil.copy(os.path.realpath(built), installed)  # as `cmake --install` puts it

            env = {k: v for k, v in os.environ.items() if k not in ("LIDARFLOW_LIBRARY", "PYTHONPATH")}
            env["PYTHONPATH"] = site
            code = ("import lidarflow, lidarflow._lib as l, lidarflow_lcm as ll, lidarflow_dask as ld; "
                    "print(l.lib._name); print(lidarflow.__version__); print(ll.__file__); print(ld.__file__); "
                    "print(ll.calibration_t.decode(ll.calibration_message(1, 1, 0, 0, 1).encode()).fx)")
            p = subprocess.run([sys.executable, "-c", code], cwd=tmp, env=env, capture_output=True, text=True)
            self.assertEqual(p.returncode, 0, p.stderr)
            name, version, lcm_init, dask_init, fx = p.stdout.split()
            self.assertEqual(name, installed)
            self.assertEqual(version, lidarflow.__version__)
            # lidarflow_lcm and lidarflow_dask come with the binding, from the same installed site folder.
            self.assertEqual(os.path.dirname(os.path.dirname(lcm_init)), site)
            self.assertEqual(os.path.dirname(os.path.dirname(dask_init)), site)
            self.assertEqual(float(fx), 1.0)


if __name__ == "__main__":
    unittest.main()

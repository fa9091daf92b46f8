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

    def test_without_numpy_the_error_names_debians_python(self):
        """A python3 without numpy (pyenv's, a plain venv's) gets an ImportError that says which
        interpreter lacks it and to use Debian's /usr/bin/python3, for both packages."""
        for package in ("lidarflow", "lidarflow_lcm"):
            code = "import sys; sys.modules['numpy'] = None; import %s" % package
            p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
            self.assertNotEqual(p.returncode, 0, p.stdout)
            last = p.stderr.strip().splitlines()[-1]
            self.assertIn("ImportError: %s needs numpy, which %s cannot import" % (package, sys.executable), last)
            self.assertIn("/usr/bin/python3", last)

    def test_readme_venv_recipe_finds_the_checkouts_library(self):
        """The README's venv recipe, as typed in a checkout: the package pip installs into the
        venv finds the checkout's build/capi/ library with no environment variable."""
        with open(os.path.join(SOURCE, "..", "..", "README.md")) as f:
            lines = f.read().splitlines()
        start = next(i for i, line in enumerate(lines) if "install it offline" in line)
        recipe = []
        for line in lines[start + 1:]:
            if not line.strip():
                if recipe:
                    break
                continue
            self.assertTrue(line.startswith("    "), "the recipe is an indented block: %r" % line)
            recipe.append(line.strip())
        self.assertTrue(any(" -m venv " in line for line in recipe), recipe)
        built = os.path.realpath(lidarflow._lib.lib._name)
        with tempfile.TemporaryDirectory() as checkout:
            shutil.copytree(SOURCE, os.path.join(checkout, "bindings", "python"),
                            ignore=shutil.ignore_patterns("tests", "tests_lcm", "__pycache__", "build", "*.egg-info"))
            os.makedirs(os.path.join(checkout, "build", "capi"))
            library = os.path.join(checkout, "build", "capi", "liblidarflow.so.0")
            shutil.copy(built, library)
            env = {k: v for k, v in os.environ.items() if k not in ("LIDARFLOW_LIBRARY", "PYTHONPATH")}
            p = subprocess.run(["bash", "-euo", "pipefail", "-c", "\n".join(recipe)], cwd=checkout, env=env,
                               capture_output=True, text=True)
            self.assertEqual(p.returncode, 0, "\n".join(recipe) + "\n" + p.stdout + p.stderr)
            venv_python = os.path.join(checkout, ".venv", "bin", "python")
            code = "import lidarflow, lidarflow._lib as l; print(l.lib._name); print(lidarflow.__file__)"
            p = subprocess.run([venv_python, "-c", code], cwd=tempfile.gettempdir(), env=env,
                               capture_output=True, text=True)
            self.assertEqual(p.returncode, 0, p.stderr)
            name, init = p.stdout.split()
            self.assertEqual(name, library)
            self.assertTrue(init.startswith(os.path.join(checkout, ".venv")), init)


if __name__ == "__main__":
    unittest.main()

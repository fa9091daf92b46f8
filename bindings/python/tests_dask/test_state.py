# SPDX-License-Identifier: MIT
"""lidarflow_dask: what a run keeps in OUT and how far it trusts it (CTest: python_dask).

  * state only under OUT/.lidarflow_dask/<safe name>/, whatever the source's name; a run
    deletes only files it made (not a user's, not another source's results);
  * results deleted or chunk logs lost after their chunk completed are recomputed; a chunk
    that yields fewer pairs than planned (a source that shrank) fails;
  * one run per OUT: a second is refused, naming the holder;
  * corrupt markers and settings files are named, read bounded, never trusted.
"""
import json
import os
import shutil
import socket
import unittest

from dask_fixture import BIN, FixtureCase, cli, flows, serial_args

if BIN:
    import lidarflow_dask as ld
    from lidarflow_dask import chunks, results, runner, state

KEYS = ["0000000000-0000000003", "0000000003-0000000006", "0000000006-0000000008"]


class State(FixtureCase):
    def copy_serial(self, name):
        out = os.path.join(self.f.folder(name), "out")
        shutil.copytree(self.f.serial, out)
        return out

    def test_safe_names(self):
        for name in ("..", ".", "a/b", ".lock", "x y", "\u00e9", ".lidarflow_dask", "%2E"):
            s = state.safe_name(name)
            self.assertNotIn("/", s)
            self.assertFalse(s.startswith("."), s)
            self.assertEqual(os.path.dirname(state.state_dir("/o", name)), "/o/.lidarflow_dask")
        self.assertEqual(state.safe_name("drive_0001_sync"), "drive_0001_sync")
        self.assertNotEqual(state.safe_name("%2E"), state.safe_name("."))

    def test_dot_dot_log_and_user_files_kept(self):
        t = self.f.folder("dots")
        log = os.path.join(t, "...log")  # its name is '..'
        shutil.copy(self.f.log, log)
        out = os.path.join(t, "out")
        os.makedirs(out)
        mine = {"x.tmp.1": b"user data", "notes.log": b"user notes", "a.log": b"another source's results"}
        for n, data in mine.items():
            with open(os.path.join(out, n), "wb") as f:
                f.write(data)
        for extra in ([], ["--force"]):
            p = cli(*serial_args(out, log) + extra)
            self.assertEqual(p.returncode, 0, p.stderr)
            for n, data in mine.items():
                with open(os.path.join(out, n), "rb") as f:
                    self.assertEqual(f.read(), data, (n, extra))
            self.assertEqual(flows(os.path.join(out, "...log")), self.f.whole)
            st = os.path.join(out, ".lidarflow_dask", "%2E.")
            self.assertEqual(sorted(os.listdir(st)), sorted(["settings.json"] + ["%s.%s" % (k, e) for k in
                                                            ("0000000000-0000000003", "0000000003-0000000006",
                                                             "0000000006-0000000007") for e in ("done", "log")]))

    def test_deleted_results_recomputed(self):
        out = self.copy_serial("deleted")
        os.unlink(os.path.join(out, "drive", "disp_1", "0000000004.png"))
        os.unlink(os.path.join(out, ".lidarflow_dask", "run", "0000000003-0000000006.log"))
        p = cli(*serial_args(out, self.f.drive, self.f.log))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("2 to compute (4 complete)", p.stderr)
        self.assertIn("frames 3:6 was complete, but 2 of its 3 results are there: recomputing", p.stderr)
        self.assertIn("frames 3:6 was complete, but 0 of its 3 results are there: recomputing", p.stderr)
        self.assertTrue(os.path.exists(os.path.join(out, "drive", "disp_1", "0000000004.png")))
        self.assertEqual(flows(os.path.join(out, "run.log")), self.f.whole)
        # A result log deleted: joined again from the chunk logs, nothing recomputed.
        os.unlink(os.path.join(out, "run.log"))
        p = cli(*serial_args(out, self.f.drive, self.f.log))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("0 to compute", p.stderr)
        self.assertEqual(flows(os.path.join(out, "run.log")), self.f.whole)

    def test_lost_chunk_log_at_merge_fails(self):
        out = self.copy_serial("merge")
        src = ld.Source(self.f.log, ld.Settings(out, **self.f.settings))
        os.unlink(chunks.chunk_log_path(src.chunks[1]))
        report = runner.Report(None, lines=False)
        # Chunk 0:3 computed by this run, chunk 3:6's log lost since it completed.
        report.add({"chunk": src.chunks[0], "host": "h", "rc": 0, "pairs": 3, "seconds": 1.0, "message": ""})
        runner.merge_logs([src], report)
        self.assertEqual(len(report.failed), 1)
        self.assertIn("0000000003-0000000006.log is missing or unreadable at the merge", report.failed[0]["message"])
        n, missing = results.merge([chunks.chunk_log_path(c) for c in src.chunks], os.path.join(out, "x.log"))
        self.assertEqual((n, missing), (4, [chunks.chunk_log_path(src.chunks[1])]))

    def test_shrunk_source_fails_its_chunk(self):
        t = self.f.folder("shrunk")
        out = os.path.join(t, "out")
        src = ld.Source(self.f.log, ld.Settings(out, **self.f.settings))
        short = os.path.join(t, "run.log")
        # The log cut after its 5th stereo frame: chunk 6:7 finds no frame, chunk 3:6 two of four.
        import lidarflow_lcm as ll
        with ll.LogReader(self.f.log) as r, ll.LogWriter(short) as w:
            n = 0
            for e in r:
                n += e.channel == "LIDARFLOW_STEREO"
                if n > 5:
                    break
                w.write(e.channel, e.data, e.utime)
        for c, planned in ((src.chunks[2], 1), (src.chunks[1], 3)):
            c = dict(c, source=short)
            r = chunks.run_chunk(c)
            self.assertNotEqual(r["rc"], 0, r)
            self.assertLess(r["pairs"], planned, r)
            self.assertFalse(os.path.exists(chunks.marker_path(c)))
            self.assertFalse(os.path.exists(chunks.chunk_log_path(c)))

    def test_second_run_refused(self):
        out = self.copy_serial("locked")
        with state.Lock(out):
            p = cli(*serial_args(out, self.f.drive, self.f.log))
            self.assertEqual(p.returncode, 2, p.stderr)
            self.assertIn("is in use by another lidarflow_dask run (pid %d on %s" % (os.getpid(), socket.gethostname()),
                          p.stderr)
            with self.assertRaises(state.Busy):
                with state.Lock(out):
                    pass
        p = cli(*serial_args(out, self.f.drive, self.f.log))
        self.assertEqual(p.returncode, 0, p.stderr)

    def test_corrupt_markers_named_and_recomputed(self):
        out = self.copy_serial("markers")
        d = os.path.join(out, ".lidarflow_dask", "drive")
        m = [os.path.join(d, k + ".done") for k in KEYS]
        with open(m[0], "w") as f:
            f.write("not json")
        os.unlink(m[1])
        os.symlink("/dev/zero", m[1])
        with open(m[2], "w") as f:
            json.dump({"host": "h", "pairs": 1e308, "seconds": 1.0, "frames": [6, 8]}, f)
        p = cli(*serial_args(out, self.f.drive), timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("%s: chunk marker is not valid JSON" % m[0], p.stderr)
        self.assertIn("%s: chunk marker is not a regular file" % m[1], p.stderr)
        self.assertIn("%s: chunk marker: pairs 1e+308" % m[2], p.stderr)
        self.assertIn("3 to compute (0 complete)", p.stderr)
        self.assertNotIn("Traceback", p.stderr)
        p = cli(*serial_args(out, self.f.drive))
        self.assertIn("0 to compute (3 complete)", p.stderr)
        for bad in (b"[]", b'{"host": "h", "pairs": 3, "seconds": NaN, "frames": [0, 3]}',
                    b'{"host": "h", "pairs": 3, "seconds": 1, "frames": [0, 4]}', b"{" * 100000, b"\xff\xfe"):
            with open(m[0], "wb") as f:
                f.write(bad)
            with self.assertRaises(state.StateError, msg=bad) as e:
                state.check_marker(m[0], 0, 3)
            self.assertIn(m[0], str(e.exception))

    def test_folder_in_a_markers_place_fails_the_chunk(self):
        out = os.path.join(self.f.folder("markerdir"), "out")
        c = ld.Source(self.f.drive, ld.Settings(out, **self.f.settings)).chunks[2]
        c["options"] = []
        os.makedirs(chunks.marker_path(c))
        r = chunks.run_chunk(c)
        self.assertEqual(r["rc"], -1, r)
        self.assertIn("cannot keep the results", r["message"])

    def test_corrupt_settings_named(self):
        out = self.copy_serial("settings")
        sp = os.path.join(out, ".lidarflow_dask", "drive", "settings.json")
        for bad, why in ((b"", "not valid JSON"), (b"[1, 2]", "not a settings file"), (b"x" * 100000, "bytes (at most")):
            with open(sp, "wb") as f:
                f.write(bad)
            p = cli(*serial_args(out, self.f.drive))
            self.assertEqual(p.returncode, 2, p.stderr)
            self.assertIn("%s: settings file" % sp if why != "not a settings file" else sp, p.stderr)
            self.assertIn(why, p.stderr)
            self.assertIn("use --force", p.stderr)
            self.assertNotIn("Traceback", p.stderr)
        os.unlink(sp)
        os.mkdir(sp)
        p = cli(*serial_args(out, self.f.drive))
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn("%s: settings file is not a regular file" % sp, p.stderr)


if __name__ == "__main__":
    unittest.main()

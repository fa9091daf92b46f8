# SPDX-License-Identifier: MIT
"""lidarflow_dask's --warm-up on LCM log chunks (CTest: python_dask), on one continuous stream: a
bot_core log of 6 frames from the bridge tests' independent generator (a box moving in front of
a background the camera drives towards), where each pair takes priors from the pair before it:

  * in chunks of 3 frames (0:2, 2:4, 4:5) warmed up by 4, every chunk's stream starts at frame
    0: the result log is the whole log's replay byte for byte (compute_seconds aside);
  * with --warm-up 0 every pair of the chunks after the first differs from it (the check can fail);
  * with --frames 2:5 the warm-up stops at frame 2, where the replay of that range starts: its
    results byte for byte.
"""
import os
import subprocess
import tempfile
import unittest

from dask_fixture import BIN, READY, SKIP, cli, egos, flows, tool

STEREO = "STEREO_CAMERA"  # the generator's channels, as a bot_core driver names them
OPTION = "matching.min_coarsest_height=16"  # the coarsest level of a 320x96 image


def differing(got, want):
    """The indices of the results (log time, bytes) that differ, or 'N results, not M'."""
    if len(got) != len(want):
        return "%d results, not %d" % (len(got), len(want))
    return [i for i, (a, b) in enumerate(zip(got, want)) if a != b]


@unittest.skipUnless(READY, SKIP)
class LogWarmUp(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls._tmp = tempfile.TemporaryDirectory()
        cls.tmp = cls._tmp.name
        cls.log = os.path.join(cls.tmp, "stream.log")
        l2c = subprocess.run([tool("bridge", "tests", "make_bot_core_log"), cls.log, cls.tmp, "6"], check=True,
                             capture_output=True, text=True).stdout.strip()
        calib = os.path.join(cls.tmp, "calib_cam_to_cam.txt")
        cls.bridge_args = ["--lidar-channel", "VELODYNE_POINTS", "--calib", calib, "--lidar-to-camera", l2c]
        cls.whole, cls.whole_ego = cls.replay("whole")
        assert len(cls.whole) == 5, "the whole replay: %d results, not 5" % len(cls.whole)

    @classmethod
    def tearDownClass(cls):
        cls._tmp.cleanup()

    @classmethod
    def replay(cls, name, *frames):
        """(flows, egos) of one bridge replay of the log (of frames A:B with `--frames A:B`)."""
        out = os.path.join(cls.tmp, name + ".log")
        subprocess.run([tool("bridge", "lidarflow-lcm-bridge"), "--replay", cls.log, "--out", out, "--option",
                        "threads=1", "--option", OPTION, "--stereo-channel", STEREO] + cls.bridge_args
                       + list(frames), check=True, capture_output=True)
        return flows(out), egos(out)

    def chunked(self, name, *args):
        """(flows, egos) of lidarflow_dask's serial run of the log in chunks of 3 frames."""
        out = os.path.join(self.tmp, name)
        p = cli(*(["--serial", "--out", out, "--chunk", "3", "--threads-per-task", "1", "--option", OPTION,
                   "--bin-dir", BIN, "--stereo-channel", STEREO]
                  + ["--bridge-arg=" + a for a in self.bridge_args] + list(args) + [self.log]))
        self.assertEqual(p.returncode, 0, p.stderr)
        return flows(os.path.join(out, "stream.log")), egos(os.path.join(out, "stream.log"))

    def test_chunks_warmed_up_from_frame_0_are_the_whole_replay(self):
        got, got_ego = self.chunked("warm", "--warm-up", "4")
        self.assertEqual(differing(got, self.whole), [])
        self.assertEqual(differing(got_ego, self.whole_ego), [])

    def test_cold_chunks_differ(self):
        got, _ = self.chunked("cold", "--warm-up", "0")
        # Pairs 0 and 1: the first chunk starts where the whole replay does; chunks 2:4 and 4:5
        # start cold, without the priors of the pairs before them.
        self.assertEqual(differing(got, self.whole), [2, 3, 4])

    def test_range_chunks_warm_up_from_the_range_start(self):
        """Chunks 2:4 and 4:5; the second's warm-up of 4 stops at frame 2."""
        ref, ref_ego = self.replay("range", "--frames", "2:5")
        self.assertEqual(len(ref), 3)
        got, got_ego = self.chunked("range", "--frames", "2:5", "--warm-up", "4")
        self.assertEqual(differing(got, ref), [])
        self.assertEqual(differing(got_ego, ref_ego), [])


if __name__ == "__main__":
    unittest.main()

/* SPDX-License-Identifier: MIT */
/*
 * lidarflow — dense scene flow from a rectified stereo camera and a sparse LiDAR.
 *
 * This is the library's one stable C ABI. Everything the shared library exports is declared
 * here; the C++ core behind it is private and no C++ exception ever crosses this boundary.
 *
 * Conventions
 *  - Every function is prefixed lf_, every type lf_*_t, every macro LF_.
 *  - Only fixed-width integer types, float/double and pointers appear in signatures and
 *    structs; enumerations name the values that int32_t fields and returns carry.
 *  - Status codes are explicitly numbered and are never renumbered; new codes are appended.
 *  - Fallible functions return an lf_status_t value as int32_t. On failure they change
 *    nothing (a handle keeps its state and stays usable) and record a message that
 *    lf_last_error() returns.
 *  - Structs that may grow begin with `uint32_t struct_size`: set it to sizeof(the struct)
 *    (the lf_*_init helpers below do). Fields are only ever appended, so a program built
 *    against an older header keeps working with a newer library.
 *  - Strings returned by the library are NUL-terminated and owned by the library; each
 *    function says how long they stay valid.
 *  - Thread safety: functions on distinct handles may run concurrently; one handle must not be
 *    used by two threads at the same time. Functions without a handle are thread-safe.
 *
 * Typical use (see examples/capi_example.c):
 *    lf_options_t *opt; lf_options_create(&opt); lf_options_set_int(opt, "threads", 4);
 *    lf_calibration_t cal; lf_calibration_init(&cal); cal.fx = ...;
 *    lf_estimator_t *est; lf_create(opt, &cal, &est); lf_options_destroy(opt);
 *    for each stereo frame: lf_push_frame(est, t_us, &left, &right, &lidar);
 *                           if (lf_has_result(est)) lf_get_result(est, &buffers);
 *    lf_destroy(est);
 */
#ifndef LIDARFLOW_H
#define LIDARFLOW_H

#include <stdint.h>
#include <string.h>

#include "lidarflow/lidarflow_version.h"

#if defined(_WIN32)
#  define LF_API
#elif defined(LIDARFLOW_BUILDING_LIBRARY)
#  define LF_API __attribute__((visibility("default")))
#else
#  define LF_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ===================================================================================== */
/* Status codes and version                                                              */
/* ===================================================================================== */

/* Result of every fallible call. Values are part of the ABI and never change. */
typedef enum lf_status_t {
    LF_OK = 0,
    LF_ERR_INVALID_ARGUMENT = 1, /* NULL pointer, out-of-range option, NaN/inf input, ... */
    LF_ERR_SIZE_MISMATCH = 2,    /* image/buffer sizes or strides disagree */
    LF_ERR_IO = 3,               /* a file could not be opened, read or written */
    LF_ERR_FORMAT = 4,           /* a file or message is corrupt or of the wrong format */
    LF_ERR_BAD_STATE = 5,        /* call not allowed in the handle's current state */
    LF_ERR_NOT_READY = 6,        /* no result yet (e.g. only one frame pushed) */
    LF_ERR_OUT_OF_MEMORY = 7,
    LF_ERR_INTERNAL = 8          /* a bug in lidarflow: please report it */
} lf_status_t;

/* Human-readable, static English description of a status code; never NULL.
 * Unknown codes give "unknown status". Thread-safe. */
LF_API const char *lf_status_string(int32_t status);

/* Run-time version of the loaded library: major * 10000 + minor * 100 + patch.
 * Compare with LF_VERSION_NUMBER to detect a header/library mismatch. Thread-safe. */
LF_API uint32_t lf_version_number(void);

/* Run-time version string of the loaded library, e.g. "0.1.0"; static, never NULL.
 * Thread-safe. */
LF_API const char *lf_version_string(void);

/* ABI major version of the loaded library (the SONAME suffix). Thread-safe. */
LF_API uint32_t lf_abi_major(void);

/* ===================================================================================== */
/* Options                                                                               */
/* ===================================================================================== */

/* Opaque set of estimator settings, read by lf_create() (which copies them). */
typedef struct lf_options lf_options_t;

/*
 * Keys. Integer keys take lf_options_set_int; float keys take lf_options_set_float or
 * lf_options_set_int; switches are integer keys taking 0 or 1; string keys take
 * lf_options_set_string. Distances are pixels of the full-resolution left image.
 *
 * general
 *   "threads"          int    [1, 256]   OpenMP threads of this handle (default: the CPUs the
 *                                        process may run on, at most 256; with
 *                                        "adaptive_threads" a frame takes only the idle ones);
 *                                        results do not depend on it
 *   "adaptive_threads" 0/1               each frame uses at most the CPUs other processes leave
 *                                        idle when it starts, at least one (default 1), so a
 *                                        shared machine never runs it slower than one thread;
 *                                        0 = always "threads". Idle workers sleep between stages
 *                                        and frames either way
 *   "frames_in_flight" int    [1, 64]    pairs one handle computes at once (default 1), each
 *                                        on a thread of its own with threads /
 *                                        frames_in_flight OpenMP threads (at least 1): more
 *                                        pairs per second where one pair does not use all the
 *                                        threads. Above 1, lf_push_frame starts the pair;
 *                                        when that makes frames_in_flight pairs in flight it
 *                                        waits for the oldest and hands it over (results in
 *                                        order, frames_in_flight - 1 pushes late; lf_flush
 *                                        hands over the rest at the end). A
 *                                        pair then starts its flow from the movers of the pair
 *                                        frames_in_flight before it (finished by then), carried
 *                                        that many steps at constant velocity, instead of the
 *                                        previous pair's; it reuses nothing else of the stream
 *                                        (no static points of earlier frames, no stereo)
 *   "preset"           string "default"  resets every option except "threads" to the preset:
 *                                        "default" (matching.method "decoupled": the LiDAR-
 *                                        guided SGM stereo and DIS flow at processing_scale
 *                                        0.65, DIS patches 6 / stride 2, superpixels sized
 *                                        by the LiDAR's density; about 3x the time of
 *                                        OpenCV's SGBM + DIS), "fast" ("default" with
 *                                        DIS patches every 3 px and ternary census with
 *                                        threshold 1: about 2.7x), "realtime"
 *                                        ("decoupled" at 0.55, stage 4
 *                                        with 20 px superpixels and 128 neighbours: about
 *                                        1.5x), "paper" (the paper's design: PatchMatch
 *                                        stage 1 at full size, every key's field default
 *                                        below where no preset value is named; about 15x)
 *                                        or "balanced" ("paper" with thin_from_level 1,
 *                                        backward_grid_step 6, fb_search_radius 2); set it
 *                                        first, then any key it should not decide
 *   "use_lidar"        0/1               master LiDAR switch (default 1); 0 = image-only
 *                                        pipeline, LiDAR inputs are then checked but unused
 *   "input.strict"     0/1               1: lf_push_frame refuses (LF_ERR_SIZE_MISMATCH) images
 *                                        of another size than the calibration's image_width x
 *                                        image_height (when not 0); 0 (default): logs a warning
 *                                        once per estimator and goes on
 *   "processing_scale" float [0.125, 1]  run every stage on the frame resized by this
 *                                        factor, results brought back to the input size
 *                                        (default 0.65; "realtime" 0.55, "paper" 1)
 *   "upscale_edge_step" float [0, 64]    bringing results back from processing_scale < 1:
 *                                        where d0, u or v jumps by more than this [px of
 *                                        the processing frame] between the 4 nearest
 *                                        pixels, a pixel takes the one nearest in
 *                                        intensity instead of their blend (default 3;
 *                                        0 = always blend)
 *   "last_stage"       string            stop after "matching", "consistency", "sparse" or
 *                                        "interpolation" (default: the dense result)
 *   "support_window"   int odd [1, 101]  side of the LiDAR support window of matching and
 *                                        consistency check (default 15)
 * "default" below is the "default" preset's value; "paper" differs from it in the keys that
 * name its value (the decoupled stage 1's keys are unused there). The values are measured on
 * KITTI; read them with lf_options_get_int / lf_options_get_float.
 * LiDAR input: points the left camera cannot see (a nearer object hides them from the camera;
 * the LiDAR, mounted elsewhere, sees past its edge) are removed before every stage. A point
 * of disparity d is hidden when a point of its window has a disparity above
 * d * (1 + ratio) + margin.
 *   "lidar.visibility_filter"      0/1               (default 1)
 *   "lidar.visibility_half_width"  int   [0, 64]     window half sizes [px] (default 6 and
 *   "lidar.visibility_half_height" int   [0, 64]     0 = from the points' ring spacing: 4 px
 *                                                    for a 64-beam scan of a KITTI-size image)
 *   "lidar.visibility_ratio"       float [0, 10]     (default 0.05)
 *   "lidar.visibility_margin"      float [0, 16384]  [px of disparity] (default 1)
 * stage 1: LiDAR-supported matching
 *   "matching.method"           string "patchmatch" (the paper's joint 4-D search, "paper") or
 *                                    "decoupled" (default): d0 and d1 by semi-global matching of
 *                                    each pair, (u, v) by dense inverse search (DIS) started
 *                                    from the tracked rigid background motion. The keys below
 *                                    marked (decoupled) apply to it only; the others to
 *                                    "patchmatch" only
 *   "matching.flow_finest_scale"      int [0, 8]    (decoupled) DIS's finest pyramid level
 *   "matching.flow_patch_size"        int [2, 32]   (decoupled) DIS patch side [px]
 *   "matching.flow_patch_stride"      int [1, 31]   (decoupled) < flow_patch_size
 *   "matching.flow_backward_patch_stride" int [0, 31] (decoupled) the backward flow's stride,
 *                                                   < flow_patch_size; only the
 *                                                   forward-backward check reads that flow
 *                                                   (0 = flow_patch_stride; "realtime" 4)
 *   "matching.flow_descent_iterations" int [1, 200] (decoupled) per patch and level
 *   "matching.flow_refine_iterations" int [0, 100]  (decoupled) variational refinement (0 = off,
 *                                                   every preset; more runs OpenCV's DIS, slower)
 *   "matching.flow_prior_track_step"  int [0, 256]  (decoupled) grid step [px] of the tracks
 *                                                   the rigid start flow is fitted to (0 = off)
 *   "matching.flow_rigid_choice_radius" int [0, 16] (decoupled) per pixel, the rigid start
 *                                                   flow instead of DIS's where its photometric
 *                                                   error over a (2r+1)^2 box is lower and the
 *                                                   pixel has a disparity (default 1; 0 = off)
 *   "matching.guided_stereo"          0/1           (decoupled) stereo of both pairs by the
 *                                                   library's SGM with each pair's LiDAR points
 *                                                   in its data cost (default 1) instead of
 *                                                   OpenCV's StereoSGBM (0)
 *   "matching.carry_lidar"            0/1           (decoupled, guided) where the input has
 *                                                   no t1 scan, the t1 stereo is guided by
 *                                                   the t0 points carried into t1 by the
 *                                                   camera's motion (default 1)
 *   "matching.stream_prior"           0/1           (decoupled) in a stream of frames, what
 *                                                   moved in the previous pair starts this
 *                                                   pair's flow with its object motion
 *                                                   (default 1)
 *   "matching.stream_lidar_frames"    int   [0, 16] (decoupled) in a stream of frames, stages
 *                                                   2-4 also see the static LiDAR points of
 *                                                   up to this many earlier frames, moved by
 *                                                   the background motion (3 in the decoupled
 *                                                   presets; 0 = only the pair's own points)
 *   guided SGM (matching.guided_stereo 1): census 9x7 costs, 8 or 4 paths
 *   "stereo.ternary_census"   0/1                a second census bit per neighbour: brighter
 *                                                by more than the threshold (default 0;
 *                                                "fast" 1): flat, noisy surfaces cost 0 at
 *                                                every disparity and are filled by the paths
 *   "stereo.census_threshold" int   [0, 64]      a census bit is set where a neighbour is
 *                                                darker (ternary: or brighter) than the
 *                                                centre by more than this (default 0; "fast" 1)
 *   "stereo.p1"               int   [0, 255]     penalty of a 1 px step (default 10)
 *   "stereo.p2"               int   [1, 1023]    penalty of a larger step (default 120), > p1
 *   "stereo.adaptive_p2"      0/1                P2 divided by the intensity step (default 1)
 *   "stereo.paths"            int   4 or 8       aggregation paths (default 8)
 *   "stereo.uniqueness_ratio" int   [0, 99]      [%] margin of the best cost (default 10)
 *   "stereo.lidar_slope"      float [0, 64]      LiDAR cost per px of |d - d_lidar| (default 4)
 *   "stereo.lidar_cap"        int   [0, 192]     largest LiDAR cost (default 40; census 0..62)
 *   "stereo.lidar_radius"     int   [0, 32]      [px] a point guides pixels this near of its
 *                                                intensity (default 3), less with distance
 *   "stereo.lidar_intensity"  int   [0, 255]     intensity tolerance of that spread (default 12)
 *   "lidar.cell"              int   [0, 64]      stages 2-4 see at most one LiDAR point per
 *                                                cell x cell px of the processing frame
 *                                                (default 0 = every point; stage 1 sees all)
 *   "matching.support_windows"  0/1  "matching.const1" 0/1  "matching.const2" 0/1
 *                                    windows and the two constraints (need use_lidar; const1
 *                                    and const2 need support_windows)
 *   "matching.use_lidar1"       0/1  use the LiDAR of the second frame
 *   "matching.keep_disparity_change" 0/1  a LiDAR rule that moves a propagated d0 moves its
 *                                   d1 along (default 1)
 *   "matching.d1_terms_anchored" 0/1  D_l^1 cases use E(l0,r1) instead of the paper's E(l1,r1)
 *                                   (default 0)
 *   "matching.grid_step"        int   [1, 32]     seed grid step
 *   "matching.backward_grid_step" int [0, 32]     seed grid step of the backward direction,
 *                                                 which only serves the round-trip check
 *                                                 (0 = grid_step; preset "balanced": 6)
 *   "matching.iterations"       int   [1, 100]    PatchMatch iterations per level
 *   "matching.thin_from_level"  int   [1, 100]    from this pyramid level on, each coarser
 *                                                 level keeps every 2nd seed per axis
 *   "matching.max_levels"       int   [1, 10]     pyramid levels at most
 *   "matching.min_coarsest_height" int [8, 4096]
 *   "matching.patch_radius"     int   [0, 16]
 *   "matching.stop_ratio"       float [0, 1]
 *   "matching.lazy_random_search" 0/1  after a level's first iteration, random search only
 *                                      for seeds whose match changed in the last visit
 *   "matching.settle_ratio"     float [0, 100]    the same for the flow and d0 searches only,
 *                                                 and only for seeds whose cost is at most this
 *                                                 x their neighbours' mean (0 = off; default 1)
 *   "matching.descriptor_bits"  int 8 or 4   4: descriptors packed to 64 bytes (4-bit codes
 *                                            and a contrast byte): less memory, but coarser
 *                                            costs where textures are faint, so textureless
 *                                            regions lose accuracy (docs/experiments/
 *                                            speed-stage1.md); default 8
 *   "matching.max_flow"         float [1, 10000]
 *   "matching.max_disparity"    float [1, 10000]
 *   "matching.const2_abs"       float [0, 10000]
 *   "matching.const2_rel"       float [0, 10]
 *   "matching.random_seed"      int   [0, 2^53]
 * stage 2-3: LiDAR-supported consistency check and sparsification
 *   "consistency.sgm_max_diff"  float (0, 10000]  |d0 - SGM disparity| limit
 *   "consistency.sgm_keep_unverified" 0/1         keep matches SGM cannot verify
 *   "consistency.sgm_num_disparities" int [16, 1024], multiple of 16
 *   "consistency.sgm_block_size" int odd [1, 31]
 *   "consistency.fb_max_flow"   float (0, 10000]  forward-backward limits
 *   "consistency.fb_max_d0"     float (0, 10000]
 *   "consistency.fb_max_d1"     float (0, 10000]
 *   "consistency.fb_search_radius" int [0, 8]
 *   "consistency.keep_unreliable_lidar" 0/1
 *   "consistency.cluster_max_flow_step" float (0, 10000]
 *   "consistency.cluster_max_disp_step" float (0, 10000]
 *   "consistency.cluster_min_size" int [1, 100000000]
 *   "consistency.keep_lidar_clusters" 0/1
 *   "consistency.sparsify_block" int [1, 64]       1 = no sparsification
 *   "consistency.sparsify_support" int odd [1, 63]
 * stage 4: LiDAR-supported robust interpolation
 *   "interpolation.use_lidar"   0/1               LiDAR anchors
 *   "interpolation.superpixel_size" int [4, 512]   (the largest, with dense LiDAR below)
 *   "interpolation.lidar_points_per_superpixel" float [0, 10000] a dense scan gets smaller
 *                                                 superpixels: sqrt(this / LiDAR points per
 *                                                 pixel), down to min_superpixel_size (default
 *                                                 2; "paper" 0 = always superpixel_size)
 *   "interpolation.min_superpixel_size" int [4, 512] (default 10; "realtime" 14)
 *   "interpolation.superpixel_disparity_weight" float [0, 10000] a dense scan's superpixels
 *                                                 (below superpixel_size) follow the stereo's
 *                                                 depth as well as colour: weight of a squared
 *                                                 disparity difference [1/px^2] against Lab's
 *                                                 squared distance (default 0 = colour only;
 *                                                 "realtime" 64)
 *   "interpolation.planar_merge" float [0, 100]  the small superpixels of that rule merged
 *                                                 back (up to superpixel_size^2 px) where
 *                                                 their LiDAR points lie on one plane within
 *                                                 this [px] (default 0.3; "realtime" and
 *                                                 "paper" 0 = never)
 *   "interpolation.merge_unseen" bool            ... and where no LiDAR point is in them or
 *                                                 their neighbours (default 1; "paper" 0)
 *   "interpolation.lidar_residual_radius" float [0, 64] each LiDAR point's d0 residual
 *                                                 (measurement minus its pixel's plane) spread
 *                                                 over the pixels of the same plane within
 *                                                 this [px] of the reduced frame (default 3;
 *                                                 "paper" 0 = off)
 *   "interpolation.num_neighbors" int [1, 4096]  geodesic nearest matches per superpixel
 *                                                 (default 256)
 *   "interpolation.iterations"  int   [0, 1000]
 *   "interpolation.initial_hypotheses" int [1, 10000]
 *   "interpolation.random_hypotheses"  int [0, 10000]
 *   "interpolation.ego_hypotheses"     int [1, 100000] RANSAC sets of the background motion
 *   "interpolation.edge_gain"   float [0, 10000]
 *   "interpolation.distance_sigma" float (0, 10000]  neighbour weight scale [px] (default 36)
 *   "interpolation.disparity_inlier" float (0, 10000]
 *   "interpolation.flow_inlier" float (0, 10000]
 *   "interpolation.lidar_anchor_distance" float [0, 10000]
 *   "interpolation.pixel_model_selection" 0/1
 *   "interpolation.exits_follow_background" 0/1  pixels that leave the image at t1 take the
 *                                   background (ego-motion) d1 and flow (default 1)
 *   "interpolation.static_d1_from_background" 0/1  matches whose flow the background
 *                                   explains take its d1 (default 1)
 *   "interpolation.lidar1_from_background" 0/1  t1 LiDAR points moved back by the background
 *                                   motion measure d0 where the matches do not contradict
 *                                   them (default 1)
 *   "interpolation.keep_lidar_values" 0/1
 *   "interpolation.random_seed" int   [0, 2^32 - 1]
 *   "interpolation.sed_model"   string            path of an OpenCV structured-edge model;
 *                                                 "" = built-in edges (default); loaded
 *                                                 by lf_create (LF_ERR_IO / LF_ERR_FORMAT)
 *
 * Errors of every options function: LF_ERR_INVALID_ARGUMENT for a NULL argument, an unknown
 * key, a value of the wrong type, NaN/inf, or a value out of bounds; the options object is
 * then unchanged and lf_options_last_error() says why.
 */

/* Creates an options object holding the defaults. *out receives it (NULL on failure); the
 * caller owns it and frees it with lf_options_destroy(). Errors: LF_ERR_INVALID_ARGUMENT
 * (out is NULL), LF_ERR_OUT_OF_MEMORY; the message is in lf_last_error(NULL). Thread-safe. */
LF_API int32_t lf_options_create(lf_options_t **out);

/* Frees an options object; NULL is a no-op. Estimators created from it are unaffected.
 * Not concurrently with another call on the same object. */
LF_API void lf_options_destroy(lf_options_t *options);

/* Sets an integer, float or switch key (see the table above). set_int also sets float keys.
 * Setters and getters: one thread at a time per options object; the object keeps no pointer
 * to the caller's strings. */
LF_API int32_t lf_options_set_int(lf_options_t *options, const char *key, int64_t value);
LF_API int32_t lf_options_set_float(lf_options_t *options, const char *key, double value);
/* Sets a string key; value is copied. */
LF_API int32_t lf_options_set_string(lf_options_t *options, const char *key, const char *value);

/* Reads an integer or switch key into *out. */
LF_API int32_t lf_options_get_int(lf_options_t *options, const char *key, int64_t *out);
/* Reads any numeric key (integer, switch or float) into *out. */
LF_API int32_t lf_options_get_float(lf_options_t *options, const char *key, double *out);
/* Reads a string key. *out points into the options object and stays valid until the next
 * call that sets an option on it, or its destruction. */
LF_API int32_t lf_options_get_string(lf_options_t *options, const char *key, const char **out);

/* Message of the most recent failed call on `options` ("" after a successful one). Owned by
 * the options object, valid until the next call on it. NULL gives lf_last_error(NULL).
 * One thread at a time per options object. */
LF_API const char *lf_options_last_error(const lf_options_t *options);

/* ===================================================================================== */
/* Calibration and inputs                                                                */
/* ===================================================================================== */

/* One camera of a rig whose images are not rectified (ROS camera_info style), row-major. */
typedef struct lf_raw_camera_t {
    double K[9];  /* intrinsics of the raw images [fx s cx; 0 fy cy; 0 0 1] */
    double D[8];  /* distortion k1 k2 p1 p2 k3 k4 k5 k6 (OpenCV's order; unused ones 0) */
    double R[9];  /* rotation raw camera -> rectified camera */
    double P[12]; /* rectified projection [f 0 cx Tx; 0 f cy 0; 0 0 1 0]; right camera: Tx = -fx * baseline */
} lf_raw_camera_t;

/* The rectified stereo camera. All lengths in metres, pixel quantities in pixels of the
 * (full-resolution) images pushed later. Accepted ranges (lf_create checks them; NaN and
 * infinities are outside every range): fx, fy in [1, 1e6] px; cx, cy in [-1e6, 1e6] px;
 * baseline in [1e-4, 1e4] m. Hence fx * baseline lies in [1e-4, 1e10] px m, and every depth
 * fx * baseline / d the library computes stays finite or is reported not valid. */
typedef struct lf_calibration_t {
    uint32_t struct_size;          /* sizeof(lf_calibration_t) */
    uint32_t has_lidar_to_camera;  /* 1: lidar_to_camera is set (needed by LF_LIDAR_POINTS_LIDAR) */
    double fx, fy;                 /* focal lengths [px], [1, 1e6] */
    double cx, cy;                 /* principal point [px], [-1e6, 1e6] */
    double baseline;               /* distance of the rectified left and right centres [m], [1e-4, 1e4] */
    /* Row-major 4x4 rigid transform from the LiDAR frame to the left rectified camera frame
     * (x right, y down, z forward): a rotation (orthonormal within 1e-3, determinant > 0), a
     * translation of at most 1000 m per axis [m], last row 0 0 0 1. */
    double lidar_to_camera[16];
    /* The fields below were added at the struct's end; a caller whose struct_size ends before
     * them (an older lidarflow.h) gets their zero values: size unknown, images rectified. */
    uint32_t image_width, image_height; /* size of the images the calibration is for [px]; 0 = unknown.
                                         * lf_push_frame warns once about another size, or refuses
                                         * it with the option "input.strict" */
    /* 1: the pushed images are raw (distorted and/or not row-aligned): lf_push_frame rectifies
     * each pair with raw_left / raw_right (tables computed once per image size), and every
     * result is in the rectified left camera that fx, fy, cx, cy, baseline describe, which must
     * equal raw_left.P's (and baseline (raw_left.P[3] - raw_right.P[3]) / fx). 3-D LiDAR input
     * (lidar_to_camera, LF_LIDAR_POINTS_CAMERA) is in that rectified left camera too, as
     * lf_read_calibration composes it. 0: the images are rectified; raw_left / raw_right unused. */
    uint32_t rectify;
    uint32_t reserved; /* 0 */
    lf_raw_camera_t raw_left, raw_right;
} lf_calibration_t;

/* struct_size of the first lf_calibration_t (up to lidar_to_camera), still accepted. */
#define LF_CALIBRATION_V1_SIZE 176u

/* Zeroes *c and sets its struct_size (call before filling the fields). */
static inline void lf_calibration_init(lf_calibration_t *c) {
    memset(c, 0, sizeof *c);
    c->struct_size = (uint32_t)sizeof *c;
}

/* Fills *out from KITTI calibration files: fx, fy, cx, cy and baseline from cam_to_cam_path
 * (calib_cam_to_cam.txt: P_rect_02 / P_rect_03), and, when velo_to_cam_path is not NULL,
 * lidar_to_camera from it (calib_velo_to_cam.txt: R, T) composed with R_rect_00 and camera 2's
 * offset in P_rect_02, i.e. the Velodyne -> left rectified camera transform that
 * LF_LIDAR_POINTS_LIDAR expects (has_lidar_to_camera = 1; without it 0 and
 * lidar_to_camera all zero). out->struct_size must be set (lf_calibration_init); *out is written only on
 * success. Errors: LF_ERR_INVALID_ARGUMENT (NULL cam_to_cam_path or out, struct_size too small),
 * LF_ERR_IO (a file cannot be read; only regular files of at most 1 MiB are opened, without
 * blocking, so a FIFO or device is refused), LF_ERR_FORMAT (a missing, duplicated or malformed
 * entry, a P_rect_02 / P_rect_03 that is not a rectified pinhole K [I | t], not a rectified pair,
 * R_rect_00 or R not a rotation, a T beyond 1000 m); the message, naming the file, is in
 * lf_last_error(NULL). Thread-safe.
 * image_width / image_height come from S_rect_02 when the file has it (written only when
 * out->struct_size reaches them). */
LF_API int32_t lf_read_kitti_calibration(const char *cam_to_cam_path, const char *velo_to_cam_path,
                                         lf_calibration_t *out);

/* Fills *out from any calibration source that docs/CALIBRATION.md describes: `calibration` is
 * a KITTI calib_cam_to_cam.txt, an OpenCV stereo calibration file (cv::FileStorage YAML or
 * XML: M1/K1 D1 M2/K2 D2 R T, R1 R2 P1 P2 when present, image_width + image_height or
 * imageSize) or "LEFT,RIGHT", two ROS camera_info YAML files; the format is told from the
 * content. A rig that is not rectified yet (distortion, rectifying rotations or a P other than
 * K) sets rectify = 1 and raw_left / raw_right (OpenCV files without R1 R2 P1 P2 are rectified
 * with cv::stereoRectify, alpha 0). velo_to_cam_path (NULL: none) is a calib_velo_to_cam.txt
 * (R, T) into the raw left camera (KITTI: camera 0), composed into lidar_to_camera with the
 * left camera's rectifying rotation and offset as lf_read_kitti_calibration does.
 * out->struct_size must be at least LF_CALIBRATION_V1_SIZE; fields beyond it are written
 * when it reaches them, and a rig that needs rectifying needs all of sizeof(lf_calibration_t).
 * *out is written only on success. Errors: LF_ERR_INVALID_ARGUMENT (NULL calibration or out,
 * struct_size too small), LF_ERR_IO (a file missing, unreadable, not a regular file or above
 * 1 MiB), LF_ERR_FORMAT (malformed, incomplete or inconsistent; the message names the file).
 * Thread-safe. */
LF_API int32_t lf_read_calibration(const char *calibration, const char *velo_to_cam_path, lf_calibration_t *out);

/* Pixel formats of lf_image_t. */
typedef enum lf_pixel_format_t {
    LF_PIXEL_GRAY8 = 1, /* one byte per pixel */
    LF_PIXEL_RGB8 = 2,  /* three bytes per pixel, red first */
    LF_PIXEL_BGR8 = 3   /* three bytes per pixel, blue first (OpenCV order) */
} lf_pixel_format_t;

/* A caller-owned, read-only image, only read during the call it is passed to. Rows are
 * stride_bytes apart (>= width * bytes per pixel); any alignment. */
typedef struct lf_image_t {
    const void *data;
    uint32_t width, height;
    uint64_t stride_bytes;
    int32_t format;  /* lf_pixel_format_t */
} lf_image_t;

/* Kinds of LiDAR input. */
typedef enum lf_lidar_kind_t {
    LF_LIDAR_NONE = 0,
    /* float32 (x, y, z) [m] in the left rectified camera frame, each taken to the nearest
     * pixel of its projection (floor(x + 0.5), as the KITTI devkit). Points behind the camera
     * (z <= 0.1 m), whose nearest pixel lies outside the image, or so close that their
     * disparity fx * baseline / z exceeds 16384 px are dropped (and logged), as the camera
     * pair does not see them; where several points land on one pixel the nearest wins. */
    LF_LIDAR_POINTS_CAMERA = 1,
    /* float32 (x, y, z) [m] in the LiDAR frame, moved by the calibration's lidar_to_camera,
     * then as LF_LIDAR_POINTS_CAMERA. */
    LF_LIDAR_POINTS_LIDAR = 2,
    /* float32 (x, y, d): pixel column, row (rounded to the nearest pixel as 3-D points are;
     * an entry whose pixel lies outside the image is dropped and logged, never the frame) and
     * disparity d = fx * baseline / z [px] in [0, 16384] (0: at infinity; no image is
     * wider). Where two entries share a pixel the larger disparity wins. */
    LF_LIDAR_DISPARITY = 3
} lf_lidar_kind_t;

/* A caller-owned list of `count` LiDAR entries, each three float32 at the start of an
 * element of stride_bytes (0 = packed, 12 bytes; e.g. 16 for KITTI x, y, z, reflectance).
 * Only read during the call. Entries must be finite. */
typedef struct lf_lidar_t {
    int32_t kind;  /* lf_lidar_kind_t */
    uint32_t count;
    const void *data;
    uint64_t stride_bytes;
} lf_lidar_t;

/* ===================================================================================== */
/* Estimator                                                                             */
/* ===================================================================================== */

/* Opaque estimator handle: settings, the previous frame and the latest result. */
typedef struct lf_estimator lf_estimator_t;

/* Creates an estimator. options may be NULL (defaults); it is copied and may be destroyed
 * afterwards; calibration is copied. *out receives the handle (NULL on failure), owned by the
 * caller until lf_destroy(). Errors: LF_ERR_INVALID_ARGUMENT (NULL calibration or out,
 * struct_size neither LF_CALIBRATION_V1_SIZE nor at least sizeof(lf_calibration_t), fx / fy /
 * cx / cy / baseline outside the ranges of lf_calibration_t, an image size above 16384 px or
 * with one side 0, rectify = 1 with raw cameras that are not a pinhole pair with rotations and
 * one rectified camera, or whose rectified camera is not fx ... baseline,
 * a lidar_to_camera that is not a finite rigid transform with last row 0 0 0 1, inconsistent options such as const1 without support
 * windows), LF_ERR_IO / LF_ERR_FORMAT (the "interpolation.sed_model" file), LF_ERR_OUT_OF_MEMORY;
 * the message is in lf_last_error(NULL). Thread-safe. */
LF_API int32_t lf_create(const lf_options_t *options, const lf_calibration_t *calibration,
                         lf_estimator_t **out);

/* Frees the estimator and everything it owns (views from it become invalid), after waiting for
 * its pairs in flight. NULL is a no-op.
 * Not concurrently with another call on the same estimator, nor from its log callback. */
LF_API void lf_destroy(lf_estimator_t *estimator);

/* Adds the next stereo frame. left and right must have the same size and format; size and
 * format stay fixed from the first frame until lf_reset(). lidar may be NULL (no LiDAR for
 * this frame). Everything is copied before the call returns.
 * From the second frame on, the call computes (synchronously) the scene flow between the
 * previous frame (t0, the reference) and this one (t1): the previous frame's LiDAR is D_l^0,
 * this frame's is D_l^1. The new result replaces the previous one. The first frame (after
 * lf_create or lf_reset; with "frames_in_flight" 1) is not idle either: its push computes what
 * the pair needs of that frame alone (its stereo disparity, or the PatchMatch presets'
 * descriptors: "paper", "balanced"; its input checks, its images at the processing size, the
 * interpolation's edges and superpixels): the first push takes that long (~0.03 s at
 * "realtime", ~0.1 s at "paper" on KITTI, two cores) and the second that much less. Results are
 * the same bit for bit. In a stream the result also
 * depends on the frames before: the decoupled presets start each pair's flow from what moved
 * in the previous pair ("matching.stream_prior") and add the static LiDAR points of the last 3
 * frames to the pair's own ("matching.stream_lidar_frames"), so a stream that starts later
 * gives other (at its start, less informed) results; lf_reset() forgets both. Both rest on one
 * frame step's motion: a pair whose time step (from timestamp_us) differs from the previous
 * pair's by more than 25 % (a dropped frame) is computed without them, and so is the pair after
 * one whose background motion could not be tracked (a cut); the log says so.
 * With a calibration of rectify = 1 the pair is rectified first (both images raw, of the size
 * the tables were made for, made again when it changes); LiDAR entries are placed in the
 * rectified left image, and every result is in the rectified left camera.
 * timestamp_us must be larger than the previous frame's (any value for the first frame).
 * Errors: LF_ERR_INVALID_ARGUMENT (NULL estimator/left/right, NULL data, zero width or
 * height or a side above 16384 px, unknown format or LiDAR kind, left/right formats differ,
 * timestamp not increasing, NULL LiDAR data with count > 0, non-finite LiDAR values,
 * disparities outside [0, 16384] px, 3-D points that the
 * calibration's lidar_to_camera moves to non-finite coordinates,
 * LF_LIDAR_POINTS_LIDAR without lidar_to_camera, images the estimator cannot work on (e.g.
 * no matchable texture)), LF_ERR_SIZE_MISMATCH (stride smaller than a row, left/right sizes
 * differ, size or format differs from the previous frame, LiDAR stride below 12 bytes, a size
 * other than the calibration's image_width x image_height with the option "input.strict"),
 * LF_ERR_BAD_STATE (called while lf_push_frame or lf_reset runs on the same estimator, e.g.
 * from the log callback of that call), LF_ERR_OUT_OF_MEMORY. On any error the estimator is
 * unchanged: the previous frame and the previous result stay.
 * With "frames_in_flight" N > 1 the call starts computing the pair on one of the handle's own
 * threads (which may call the log callback: from there, on the same handle, lf_push_frame,
 * lf_flush, lf_reset and the result readers return LF_ERR_BAD_STATE, lf_has_result 0, and
 * lf_last_error gives that thread's message) and, when that makes N pairs in flight, waits for
 * the oldest and makes its result the current one: the result of the pair that ended with
 * frame k comes with the push of frame k + N - 1 (or lf_flush). The errors above are
 * then this frame's; a pair that fails is handed over without a result: lf_has_result is 0
 * and the result readers (lf_get_result_info, ...) return its error, whose message names the
 * pair's timestamps. A push that hands nothing over (fewer than N pairs in flight: the first
 * N - 1 pairs, and again after lf_flush) leaves no result either.
 * One thread at a time per estimator (this and every function below that takes one);
 * distinct estimators may push concurrently. */
LF_API int32_t lf_push_frame(lf_estimator_t *estimator, int64_t timestamp_us, const lf_image_t *left,
                             const lf_image_t *right, const lf_lidar_t *lidar);

/* With "frames_in_flight" > 1: waits for the oldest pair in flight and hands it over as
 * lf_push_frame does (its result becomes the current one; a failed pair leaves none, and the
 * readers return its error). At the end of a stream, take every remaining result with
 *     while (lf_flush(est) == LF_OK) if (lf_has_result(est)) ... read the result ...
 * Errors: LF_ERR_INVALID_ARGUMENT (NULL), LF_ERR_NOT_READY (no pair in flight; always so with
 * "frames_in_flight" 1, whose pushes compute their pair), LF_ERR_BAD_STATE (as lf_push_frame).
 * A pair that ran out of memory is handed over as failed (LF_ERR_OUT_OF_MEMORY from the
 * readers). One thread at a time per estimator. Added in 0.3.0. */
LF_API int32_t lf_flush(lf_estimator_t *estimator);

/* Forgets the previous frame, the result and what the stream carried (the next push starts a
 * new sequence, any size, as on a fresh estimator); pairs in flight are waited for and dropped;
 * views from the estimator become invalid. Errors: LF_ERR_INVALID_ARGUMENT (NULL),
 * LF_ERR_BAD_STATE (as lf_push_frame: called from inside a call on the same estimator).
 * One thread at a time per estimator. */
LF_API int32_t lf_reset(lf_estimator_t *estimator);

/* 1 when a result is available (two frames pushed since creation or lf_reset; with
 * "frames_in_flight" N, a pair handed over by the last push or flush and not failed), else 0
 * (also for NULL). Changes nothing, not even the last error. One thread at a time per
 * estimator. */
LF_API int32_t lf_has_result(const lf_estimator_t *estimator);

/* Stages, as reported by lf_result_info_t.last_stage (same order as the "last_stage" names). */
typedef enum lf_stage_t {
    LF_STAGE_MATCHING = 1,
    LF_STAGE_CONSISTENCY = 2,
    LF_STAGE_SPARSE = 3,
    LF_STAGE_INTERPOLATION = 4
} lf_stage_t;

/* Facts about the latest result. */
typedef struct lf_result_info_t {
    uint32_t struct_size;      /* set by the caller: sizeof(lf_result_info_t) */
    uint32_t width, height;    /* size of the result planes (= the images') */
    int32_t last_stage;        /* lf_stage_t the result comes from */
    int64_t t0_us, t1_us;      /* timestamps of the reference (t0) and the second (t1) frame */
    uint32_t timing_count;     /* number of entries lf_get_timing() knows */
    double total_seconds;      /* wall time of the computation */
    /* Fields added in 0.2.0 (a struct_size of LF_RESULT_INFO_V1_SIZE leaves them out): */
    uint32_t rectified;        /* 1: the pair was rectified inside (calibration rectify = 1), so
                                  every result is in the rectified left camera; 0: as pushed */
    uint32_t reserved;         /* 0 */
} lf_result_info_t;

/* The struct_size of lf_result_info_t before the fields of 0.2.0. */
#define LF_RESULT_INFO_V1_SIZE 48u

static inline void lf_result_info_init(lf_result_info_t *i) {
    memset(i, 0, sizeof *i);
    i->struct_size = (uint32_t)sizeof *i;
}

/* Fills *info (caller-owned) up to its struct_size: LF_RESULT_INFO_V1_SIZE (the first layout)
 * or at least sizeof(lf_result_info_t). Errors: LF_ERR_INVALID_ARGUMENT (NULL, another
 * struct_size), LF_ERR_NOT_READY (no result yet). One thread at a time per estimator. */
LF_API int32_t lf_get_result_info(lf_estimator_t *estimator, lf_result_info_t *info);

/* Per-stage timing `index` (0 .. timing_count - 1, in execution order) of the latest result:
 * *name (e.g. "matching_forward", "interpolation"; "rectify" first for a calibration with
 * rectify = 1: the pushed pair's rectification; owned by the estimator, valid until the
 * next push, flush, reset or destroy) and *seconds. Either output may be NULL. Errors:
 * LF_ERR_INVALID_ARGUMENT (NULL estimator, index out of range), LF_ERR_NOT_READY. One thread
 * at a time per estimator. */
LF_API int32_t lf_get_timing(lf_estimator_t *estimator, uint32_t index, const char **name, double *seconds);

/* A caller-owned output plane: rows stride_bytes apart (>= width * element size); any
 * alignment. data = NULL skips the plane. */
typedef struct lf_plane_t {
    void *data;
    uint64_t stride_bytes;
} lf_plane_t;

/* Caller buffers for lf_get_result(). The result lives in the left image at t0; per pixel:
 * u, v  float32 optical flow to the left image at t1 [px];
 * d0    float32 disparity at t0 [px];  d1 float32 disparity at t1 of the same point [px];
 * valid uint8 1 where (u, v, d0, d1) is defined, 0 elsewhere (the dense result of the
 *       interpolation stage is valid everywhere; earlier stages are sparse); u, v, d0, d1 are
 *       NaN where valid is 0 (docs/CONVENTIONS.md; 0 in 0.1.0);
 * confidence float32 >= 0, larger is better, 0 where not valid. */
typedef struct lf_result_buffers_t {
    uint32_t struct_size;    /* sizeof(lf_result_buffers_t) */
    uint32_t width, height;  /* must equal the result's */
    lf_plane_t u, v, d0, d1; /* float32 */
    lf_plane_t valid;        /* uint8 */
    lf_plane_t confidence;   /* float32 */
} lf_result_buffers_t;

static inline void lf_result_buffers_init(lf_result_buffers_t *b) {
    memset(b, 0, sizeof *b);
    b->struct_size = (uint32_t)sizeof *b;
}

/* Copies the latest result into the non-NULL planes of *buffers. Errors:
 * LF_ERR_INVALID_ARGUMENT (NULL, struct_size too small), LF_ERR_NOT_READY,
 * LF_ERR_SIZE_MISMATCH (width/height differ from the result, a stride smaller than a row).
 * Nothing is written on error. The planes stay the caller's; only written during the call.
 * One thread at a time per estimator. */
LF_API int32_t lf_get_result(lf_estimator_t *estimator, const lf_result_buffers_t *buffers);

/* A read-only plane owned by the estimator. */
typedef struct lf_view_t {
    const void *data;
    uint64_t stride_bytes;
} lf_view_t;

/* Borrowed views of the latest result, same meaning as lf_result_buffers_t. */
typedef struct lf_result_views_t {
    uint32_t struct_size;    /* set by the caller: sizeof(lf_result_views_t) */
    uint32_t width, height;
    lf_view_t u, v, d0, d1, valid, confidence;
} lf_result_views_t;

static inline void lf_result_views_init(lf_result_views_t *v) {
    memset(v, 0, sizeof *v);
    v->struct_size = (uint32_t)sizeof *v;
}

/* Fills *views with pointers into the estimator; they stay valid until the next
 * lf_push_frame, lf_flush, lf_reset or lf_destroy on it (a failed push keeps them valid). Errors:
 * LF_ERR_INVALID_ARGUMENT (NULL, struct_size too small), LF_ERR_NOT_READY. Read them only
 * while no other thread calls into the estimator. */
LF_API int32_t lf_get_result_views(lf_estimator_t *estimator, lf_result_views_t *views);

/* Caller buffers for lf_get_points3d(). */
typedef struct lf_points3d_buffers_t {
    uint32_t struct_size;    /* sizeof(lf_points3d_buffers_t) */
    uint32_t width, height;  /* must equal the result's */
    /* float32 (x, y, z) per pixel [m]: the point seen at the pixel at t0, in the left
     * camera frame at t0. */
    lf_plane_t points;
    /* float32 (dx, dy, dz) per pixel [m]: its position at t1, in the left camera frame at
     * t1, minus its position at t0 (scene flow relative to the camera: includes ego-motion). */
    lf_plane_t motion;
    /* uint8: 1 where the result is valid with d0 > 0 and d1 > 0 and every coordinate of
     * points and motion fits a float32 (a disparity near 0 puts the point at a depth none
     * holds); elsewhere points and motion are NaN. */
    lf_plane_t valid;
} lf_points3d_buffers_t;

static inline void lf_points3d_buffers_init(lf_points3d_buffers_t *b) {
    memset(b, 0, sizeof *b);
    b->struct_size = (uint32_t)sizeof *b;
}

/* Converts the latest result with the calibration (Z = fx * baseline / d, X = (x - cx) Z / fx,
 * Y = (y - cy) Z / fy) into the non-NULL planes of *buffers (points and motion rows hold
 * 12 bytes per pixel). Errors, ownership and threads as lf_get_result(). */
LF_API int32_t lf_get_points3d(lf_estimator_t *estimator, const lf_points3d_buffers_t *buffers);

/* ----- Ego-motion and object motion ------------------------------------------------- */

/* Whether lf_ego_motion_t.transform holds the camera's metric ego-motion (values never change;
 * new ones are appended). lf_create requires a calibration and no option key turns the model
 * off, so through this ABI only LF_EGO_OK, LF_EGO_NOT_RUN and LF_EGO_TOO_FEW_INLIERS occur
 * today; the others name what the core reports to its other front ends (the CLI). */
typedef enum lf_ego_state_t {
    LF_EGO_OK = 0,
    LF_EGO_NOT_RUN = 1,          /* the result comes from a stage before interpolation ("last_stage") */
    LF_EGO_NO_CALIBRATION = 2,   /* the estimator has no stereo calibration (all-zero): image terms only */
    LF_EGO_TOO_FEW_INLIERS = 3,  /* the matches agree on no dominant rigid (background) motion */
    LF_EGO_DISABLED = 4          /* the options turn the rigid background model off */
} lf_ego_state_t;

/* The rigid motion of the static scene between the result's two frames, as stage 4
 * (interpolation) fits it to the sparse matches (RANSAC, then a refit on its inliers).
 * Convention: transform = T maps the coordinates of a static point in the left rectified camera
 * frame at t0 (X0, metres) to its coordinates in that camera's frame at t1:
 *     X1 = T * [X0; 1],   T = [R t; 0 0 0 1]   (row-major: transform[4 * row + col]).
 * The camera's own motion (its pose at t1 expressed in its frame at t0) is T^-1. Driving
 * forward makes t[2] (transform[11]) negative: static points come closer. */
typedef struct lf_ego_motion_t {
    uint32_t struct_size;   /* set by the caller: sizeof(lf_ego_motion_t) */
    int32_t state;          /* lf_ego_state_t; transform is the identity unless LF_EGO_OK */
    double transform[16];   /* T, row-major, translation in metres */
    uint32_t inliers;       /* matches the motion explains (d1 within 1 px, flow within 2 px at the
                             * processing resolution) */
    uint32_t candidates;    /* matches the fit saw (0 when no fit ran) */
} lf_ego_motion_t;

static inline void lf_ego_motion_init(lf_ego_motion_t *e) {
    memset(e, 0, sizeof *e);
    e->struct_size = (uint32_t)sizeof *e;
}

/* Fills *ego (caller-owned) from the latest result; no computation (the fit ran with the
 * result). Returns LF_OK whenever it filled *ego, also when ego->state says there is no
 * metric ego-motion (then transform is the identity; inliers and candidates report what a fit
 * saw). Errors: LF_ERR_INVALID_ARGUMENT (NULL, struct_size too small), LF_ERR_NOT_READY (no
 * result yet). One thread at a time per estimator. */
LF_API int32_t lf_get_ego_motion(lf_estimator_t *estimator, lf_ego_motion_t *ego);

/* Caller buffers for lf_get_object_motion(). */
typedef struct lf_object_motion_buffers_t {
    uint32_t struct_size;    /* sizeof(lf_object_motion_buffers_t) */
    uint32_t width, height;  /* must equal the result's */
    /* float32 (mx, my, mz) per pixel [m]: X1 - T X0 with X0, X1 the pixel's point at t0 and
     * t1 (as lf_get_points3d) and T of lf_get_ego_motion: the scene flow with the camera's own
     * motion taken out, in the left camera frame at t1. About 0 on the static world. */
    lf_plane_t motion;
    /* uint8: 1 where lf_points3d_buffers_t.valid is 1 and the object motion fits a float32
     * (in practice: the same pixels); elsewhere motion is NaN. */
    lf_plane_t valid;
} lf_object_motion_buffers_t;

static inline void lf_object_motion_buffers_init(lf_object_motion_buffers_t *b) {
    memset(b, 0, sizeof *b);
    b->struct_size = (uint32_t)sizeof *b;
}

/* Writes the latest result's object motion into the non-NULL planes of *buffers (motion rows
 * hold 12 bytes per pixel). Errors as lf_get_points3d(), plus LF_ERR_BAD_STATE when
 * lf_get_ego_motion() reports a state other than LF_EGO_OK (the message says which). Nothing
 * is written on error. The planes stay the caller's; only written during the call. One thread
 * at a time per estimator. */
LF_API int32_t lf_get_object_motion(lf_estimator_t *estimator, const lf_object_motion_buffers_t *buffers);

/* ----- End of ego-motion and object motion ------------------------------------------- */

/* ----- Input quality ------------------------------------------------------------------- */

/* What the estimator found wrong with the inputs of the latest result: bits of the flags of
 * lf_get_quality (0 = ok). Each push checks its frame in a few milliseconds before estimating;
 * a flagged result is computed all the same, but describes the wrong inputs, not the scene.
 * docs/CONVENTIONS.md says what each means and what to do. Bits are never renumbered; new ones
 * are appended. */
typedef enum lf_quality_flag_t {
    LF_QUALITY_LEFT_RIGHT_SWAPPED = 1,        /* matching features lie at negative disparities */
    LF_QUALITY_NOT_RECTIFIED = 2,             /* rows of matching features disagree */
    LF_QUALITY_CALIBRATION_SIZE_MISMATCH = 4, /* the calibration describes images of another size */
    LF_QUALITY_BLANK_FRAME = 8,               /* an image is black, saturated or uniform, or t1
                                               * repeats t0 bit for bit (a frozen camera) */
    LF_QUALITY_LIDAR_DISAGREES = 16           /* LiDAR and image disparities disagree beyond what a
                                               * calibrated rig leaves (a wrong lidar_to_camera) */
} lf_quality_flag_t;

/* The input quality of the latest result: *flags (lf_quality_flag_t bits, 0 = ok) and *reason
 * (one English clause per set flag, "; "-separated, "" when ok; owned by the estimator, valid
 * until the next push, flush, reset or destroy). Either output may be NULL. Errors:
 * LF_ERR_INVALID_ARGUMENT (NULL estimator), LF_ERR_NOT_READY (no result yet). One thread at a
 * time per estimator. A push that fails on inputs the checks flagged (e.g. swapped images in
 * which no stage finds a match) ends its message with "(input quality: NAME[, NAME...] (reason))".
 * lf_calibration_t says nothing of the image size yet: LF_QUALITY_CALIBRATION_SIZE_MISMATCH is
 * reserved for when it does. */
LF_API int32_t lf_get_quality(lf_estimator_t *estimator, uint32_t *flags, const char **reason);

/* The name of one flag ("left_right_swapped", "not_rectified", "calibration_size_mismatch",
 * "blank_frame", "lidar_disagrees"), "ok" for 0, "unknown" for anything else (several bits, an
 * unknown bit). Static, never NULL. Thread-safe. */
LF_API const char *lf_quality_name(uint32_t flag);

/* ----- End of input quality ------------------------------------------------------------ */

/* Message of the most recent failed call on `estimator` ("" after a successful one). Owned by
 * the estimator, valid until the next call on it.
 * lf_last_error(NULL) is the message of the calling thread's most recent failed call (of any
 * lf_ function, including those without a handle such as lf_create); valid until that thread's
 * next failed call. Never NULL. One thread at a time per estimator; NULL is thread-safe. */
LF_API const char *lf_last_error(const lf_estimator_t *estimator);

/* ===================================================================================== */
/* Log messages                                                                          */
/* ===================================================================================== */

/* Severity of a library message; numbered as Python's logging levels. */
typedef enum lf_log_level_t {
    LF_LOG_DEBUG = 10,   /* detail of a decision, e.g. points the visibility filter removed */
    LF_LOG_INFO = 20,    /* what the library decided, e.g. LiDAR points outside the image */
    LF_LOG_WARNING = 30, /* a fallback: e.g. every LiDAR point dropped, no background motion */
    LF_LOG_ERROR = 40    /* reserved for failures the status codes cannot carry */
} lf_log_level_t;

/* Receives one message: level (lf_log_level_t), message (NUL-terminated, one line, without a
 * newline; it names the estimator handle and frame, e.g. "estimator 0x55d0c0a0 frame 2000 us:
 * 17 of 20 LiDAR points dropped: ...", and is valid only during the call) and the `user`
 * pointer given to lf_set_log_callback. It may be called from any thread that runs a library
 * call, concurrently from several, while the library holds none of its locks; it may call
 * lf_set_log_callback (other lidarflow calls it makes log nothing). It must not unwind (no
 * C++ exception or longjmp out of it). */
typedef void (*lf_log_fn)(int32_t level, const char *message, void *user);

/* Sends the library's messages of level >= min_level to fn, process-wide (every handle, every
 * thread); fn = NULL is silent, the default. Replaces the previous callback. When the call
 * returns, no call of an earlier callback is running any more (so its `user` may be freed),
 * except when it is called from inside a callback, which returns at once. The caller owns
 * `user`; the library only passes it on. Thread-safe, also while other threads push frames.
 * Errors: LF_ERR_INVALID_ARGUMENT (min_level outside [LF_LOG_DEBUG, LF_LOG_ERROR] with a
 * non-NULL fn; nothing changes); the message is in lf_last_error(NULL). */
LF_API int32_t lf_set_log_callback(lf_log_fn fn, int32_t min_level, void *user);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* LIDARFLOW_H */

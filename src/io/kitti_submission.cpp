// SPDX-License-Identifier: MIT
#include "io/kitti_submission.hpp"

#include "core/error.hpp"
#include "core/maps.hpp"
#include "io/kitti_layout.hpp"
#include "io/kitti_png.hpp"

namespace lidarflow::io {
namespace {

DisparityMap masked(const cv::Mat1f &d, const cv::Mat1b &valid) {
    DisparityMap out = filled(d.size(), kInvalidDisparity);
    d.copyTo(out, valid);
    return out;
}

}  // namespace

DisparityMap field_disparity0(const SceneFlowField &f) { return masked(f.d0, f.valid); }
DisparityMap field_disparity1(const SceneFlowField &f) { return masked(f.d1, f.valid); }

FlowField field_flow(const SceneFlowField &f) {
    return {f.u.clone(), f.v.clone(), (f.valid != 0) / 255};
}

void write_submission(const std::string &out_root, const std::string &id, const SceneFlowField &f) {
    require(!f.u.empty(), ErrorCode::InvalidArgument, "write_submission: empty scene-flow field");
    const KittiLayout out{out_root};
    write_disparity_png(out.est_disp0(id), field_disparity0(f));
    write_disparity_png(out.est_disp1(id), field_disparity1(f));
    write_flow_png(out.est_flow(id), field_flow(f));
}

}  // namespace lidarflow::io

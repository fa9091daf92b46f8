// SPDX-License-Identifier: MIT
#include "consistency/ground_truth_fields.hpp"

#include <cmath>

#include "consistency/validate.hpp"
#include "core/error.hpp"

namespace lidarflow::consistency {

GroundTruthFields fields_from_ground_truth(const DisparityMap &d0, const DisparityMap &d1, const FlowField &flow) {
    require(!d0.empty(), ErrorCode::InvalidArgument, "fields_from_ground_truth: empty d0");
    const int h = d0.rows, w = d0.cols;
    detail::check_size(d1, h, w, "ground-truth d1");
    detail::check_size(flow.u, h, w, "ground-truth flow u");
    detail::check_size(flow.v, h, w, "ground-truth flow v");
    detail::check_size(flow.valid, h, w, "ground-truth flow valid");

    GroundTruthFields g{SceneFlowField::zeros(w, h), SceneFlowField::zeros(w, h)};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float a = d0(y, x), b = d1(y, x), u = flow.u(y, x), v = flow.v(y, x);
            if (!disparity_valid(a) || !disparity_valid(b) || !flow.valid(y, x)) continue;
            require(std::isfinite(a) && std::isfinite(b) && std::isfinite(u) && std::isfinite(v),
                    ErrorCode::InvalidArgument, "fields_from_ground_truth: non-finite ground truth");
            SceneFlowField &f = g.forward;
            f.u(y, x) = u;
            f.v(y, x) = v;
            f.d0(y, x) = a;
            f.d1(y, x) = b;
            f.valid(y, x) = 1;
            f.confidence(y, x) = 1.0f;

            const float qx = std::round(x + u), qy = std::round(y + v);
            if (!(qx >= 0 && qy >= 0 && qx < w && qy < h)) continue;
            const int ix = static_cast<int>(qx), iy = static_cast<int>(qy);
            SceneFlowField &bw = g.backward;
            if (bw.valid(iy, ix) && bw.d0(iy, ix) >= b) continue;  // a nearer point already there
            bw.u(iy, ix) = -u;
            bw.v(iy, ix) = -v;
            bw.d0(iy, ix) = b;
            bw.d1(iy, ix) = a;
            bw.valid(iy, ix) = 1;
            bw.confidence(iy, ix) = 1.0f;
        }
    return g;
}

}  // namespace lidarflow::consistency

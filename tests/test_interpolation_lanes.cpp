// SPDX-License-Identifier: MIT
// Stage 4's robust cost lanes: every instruction set gives the portable loop's sums bit for bit
// (results must not depend on the machine), NaN residuals and both model kinds included.
#include "test_support.hpp"

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "interpolation/piecewise_model.hpp"

using namespace lidarflow::interpolation;

namespace {

bool same_bits(const float a[8], const float b[8]) { return std::memcmp(a, b, 8 * sizeof(float)) == 0; }

void every_isa_gives_the_portable_sums(void **) {
    std::mt19937 gen(7);
    std::uniform_real_distribution<float> coord(0.0f, 1242.0f), value(-50.0f, 300.0f), weight(0.0f, 1.0f);
    int compared = 0;
    for (int n : {0, 8, 16, 256, 1024})
        for (int dims : {1, 2})
            for (int trial = 0; trial < 20; ++trial) {
                std::vector<float> x(n), y(n), z0(n), z1(n), w(n);
                for (int j = 0; j < n; ++j) {
                    x[j] = coord(gen);
                    y[j] = coord(gen) * 0.3f;
                    z0[j] = value(gen);
                    z1[j] = value(gen);
                    w[j] = weight(gen);
                }
                if (n > 0 && trial % 5 == 0) z0[static_cast<size_t>(trial) % n] = std::nanf("");
                Model m;
                m.p[0] = {value(gen) * 1e-3f, value(gen) * 1e-3f, value(gen)};
                m.p[1] = {value(gen) * 1e-3f, value(gen) * 1e-3f, value(gen)};
                const float tau = trial % 2 ? 2.0f : 3.0f;
                float ref[8] = {1, 2, 3, 4, 5, 6, 7, 8};  // sums continue from acc
                robust_lanes(m, dims, x.data(), y.data(), z0.data(), z1.data(), w.data(), n, tau, ref,
                             LaneIsa::Portable);
                for (LaneIsa isa : {LaneIsa::Best, LaneIsa::Sse2, LaneIsa::Avx2}) {
                    if (!lane_isa_available(isa)) continue;
                    float acc[8] = {1, 2, 3, 4, 5, 6, 7, 8};
                    robust_lanes(m, dims, x.data(), y.data(), z0.data(), z1.data(), w.data(), n, tau, acc, isa);
                    assert_true(same_bits(acc, ref));
                    ++compared;
                }
            }
    assert_true(compared >= 200);  // at least Best and one instruction set on every case
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(every_isa_gives_the_portable_sums),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}

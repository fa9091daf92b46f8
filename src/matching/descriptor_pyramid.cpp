// SPDX-License-Identifier: MIT
#include "matching/descriptor_pyramid.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <functional>

#include <opencv2/imgproc.hpp>

#include "core/parallel_errors.hpp"
#include "core/pixels.hpp"

namespace lidarflow::matching {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// One job per image, images in parallel; each job's descriptor loops get the threads left.
void run_image_jobs(const std::vector<std::function<void(int)>> &jobs, int threads) {
    const int n = static_cast<int>(jobs.size());
    if (n == 0) return;
    const int outer = std::max(1, std::min(threads, n));
    const int inner = std::max(1, threads / outer);
    ParallelErrors errors;  // descriptor images are large: bad_alloc is likely here
#pragma omp parallel for schedule(static) num_threads(outer)
    for (int i = 0; i < n; ++i) errors.run([&] { jobs[i](inner); });
    errors.rethrow_if_any();
}

const cv::Mat &image_of(const DescriptorPyramid &m, int i) { return i % 2 == 0 ? m.pair[i / 2]->left : m.pair[i / 2]->right; }

}  // namespace

int pyramid_levels(const MatchingOptions &o, int width, int height) {
    int nlev = 1;
    while (nlev < o.max_levels && (height >> nlev) >= o.min_coarsest_height && (width >> nlev) >= 8) ++nlev;
    return nlev;
}

void DescriptorPyramid::init(const MatchInput &in, std::shared_ptr<const StereoFeatures> reuse_t0,
                             std::shared_ptr<StereoFeatures> storage) {
    // The t0 pair's full-resolution descriptors come from the previous frame when it is the
    // same stereo pair (streaming: that frame's t1); everything else is computed here or later.
    const bool reuse0 = reuse_t0 && reuse_t0->matches(in.left0, in.right0, opt);
    auto fresh0 = reuse0 ? nullptr : std::make_shared<StereoFeatures>();
    auto fresh1 = storage ? std::move(storage) : std::make_shared<StereoFeatures>();
    pending[0] = fresh0.get();
    pending[1] = fresh1.get();
    const cv::Mat *src[2][2] = {{&in.left0, &in.right0}, {&in.left1, &in.right1}};
    for (int t = 0; t < 2; ++t)
        if (pending[t]) {
            pending[t]->left = src[t][0]->clone();
            pending[t]->right = src[t][1]->clone();
            pending[t]->sift = opt.sift;
        }
    pair[0] = reuse0 ? reuse_t0 : std::shared_ptr<const StereoFeatures>(fresh0);
    pair[1] = fresh1;
    reused_t0 = reuse0;

    // Level sizes as cv::pyrDown makes them; descriptor images have their image's size.
    const int nlev = pyramid_levels(opt, width, height);
    levels.resize(nlev);
    for (int i = 0; i < 4; ++i) coarse[i].resize(nlev - 1);
    for (int l = 0; l < nlev; ++l) {
        Level &lev = levels[l];
        lev.w = l == 0 ? width : (levels[l - 1].w + 1) / 2;
        lev.h = l == 0 ? height : (levels[l - 1].h + 1) / 2;
        for (int i = 0; i < 4; ++i) lev.desc[i] = l == 0 ? &pair[i / 2]->desc[i % 2] : &coarse[i][l - 1];
    }
}

bool DescriptorPyramid::coarse_lent() const {
    for (const auto &c : coarse)
        for (const features::DescriptorImage &d : c)
            if (d.lent) return true;
    return false;
}

void DescriptorPyramid::describe_coarse(bool lend) {
    const int nlev = static_cast<int>(levels.size());
    if (nlev < 2) return;
    bool complete = true;
    for (const auto &c : coarse)
        for (const features::DescriptorImage &d : c) complete = complete && !d.empty();
    // Lent levels live in the t1 pair's full-resolution buffers, which a single run needs at the
    // same time: it recomputes them into owned storage.
    if (complete && (lend || !coarse_lent())) return;
    const auto t0 = Clock::now();
    release_coarse();
    // Each image's levels go to consecutive 64-byte aligned slices of the two buffers, sized for
    // the full resolution first (sizing touches no page; a recycled pair already has the size).
    std::vector<uint8_t *> memory(4 * (nlev - 1), nullptr);
    const auto round64 = [](size_t n) { return (n + 63) / 64 * 64; };
    if (lend && pending[1]) {
        const size_t need = features::descriptor_bytes(width, height, opt.sift) + 64;
        uint8_t *base[2];
        size_t used[2] = {0, 0}, room[2];
        for (int b = 0; b < 2; ++b) {
            auto &data = pending[1]->desc[b].data;
            if (data.size() < need) {
                data.clear();  // a growing resize would copy the old bytes over first
                data.resize(need);
            }
            const auto addr = reinterpret_cast<std::uintptr_t>(data.data());
            base[b] = data.data() + (round64(addr) - addr);
            room[b] = data.size() - static_cast<size_t>(base[b] - data.data());
        }
        int b = 0;
        for (int i = 0; i < 4; ++i)
            for (int l = 1; l < nlev; ++l) {
                const size_t bytes = round64(features::descriptor_bytes(levels[l].w, levels[l].h, opt.sift));
                while (b < 2 && used[b] + bytes > room[b]) ++b;
                if (b == 2) break;  // the rest in owned storage
                memory[i * (nlev - 1) + l - 1] = base[b] + used[b];
                used[b] += bytes;
            }
    }
    std::vector<std::function<void(int)>> jobs;
    for (int i = 0; i < 4; ++i)
        jobs.emplace_back([this, i, nlev, &memory](int inner) {
            cv::Mat1f g = features::to_gray_float(image_of(*this, i));
            for (int l = 1; l < nlev; ++l) {
                cv::Mat1f next;
                cv::pyrDown(g, next);
                g = next;
                features::compute_dense_sift(g, opt.sift, inner, coarse[i][l - 1], memory[i * (nlev - 1) + l - 1]);
            }
        });
    run_image_jobs(jobs, opt.threads);
    seconds_features += seconds_since(t0);
}

void DescriptorPyramid::release_coarse() {
    for (auto &c : coarse)
        for (features::DescriptorImage &d : c) d = features::DescriptorImage();
}

void DescriptorPyramid::describe_full() {
    if (!pending[0] && !pending[1]) return;
    if (pending[1] && coarse_lent()) release_coarse();  // their memory is overwritten now
    const auto t0 = Clock::now();
    std::vector<StereoFeatures *> to_describe;
    for (StereoFeatures *p : pending)
        if (p) to_describe.push_back(p);
    describe_pairs(to_describe, opt);
    pending[0] = pending[1] = nullptr;
    seconds_features += seconds_since(t0);
}

void describe_pairs(const std::vector<StereoFeatures *> &pairs, const MatchingOptions &opt) {
    std::vector<std::function<void(int)>> jobs;
    for (StereoFeatures *p : pairs)
        for (int k = 0; k < 2; ++k)
            jobs.emplace_back([p, k, &opt](int inner) {
                features::compute_dense_sift(features::to_gray_float(k == 0 ? p->left : p->right), opt.sift, inner,
                                             p->desc[k]);
            });
    run_image_jobs(jobs, opt.threads);
}

bool StereoFeatures::matches(const cv::Mat &l, const cv::Mat &r, const MatchingOptions &o) const {
    return !desc[0].empty() && !desc[1].empty() && sift.cell_size == o.sift.cell_size && sift.dim == o.sift.dim &&
           sift.bits == o.sift.bits && sift.clip == o.sift.clip && sift.norm_floor == o.sift.norm_floor &&
           pixel_identical(left, l) && pixel_identical(right, r);
}

}  // namespace lidarflow::matching

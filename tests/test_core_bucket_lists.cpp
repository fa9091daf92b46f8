// SPDX-License-Identifier: MIT
// core/bucket_lists.hpp: every bucket lists exactly the items whose range covers it, in the
// items' order, for random ranges (single buckets, spans, empty ranges, empty buckets).
#include <algorithm>
#include <cstddef>
#include <random>
#include <vector>

#include "core/bucket_lists.hpp"
#include "test_support.hpp"

namespace {

void lists_each_bucket_in_item_order(void **) {
    std::mt19937 gen(3);
    for (int buckets : {1, 7, 64}) {
        for (size_t n : {size_t{0}, size_t{1}, size_t{300}}) {
            std::uniform_int_distribution<int> at(0, buckets - 1), span(-1, 3);
            std::vector<int> lo(n), hi(n);
            for (size_t i = 0; i < n; ++i) {
                lo[i] = at(gen);
                hi[i] = std::min(buckets - 1, lo[i] + span(gen));  // span -1: no bucket
            }
            const lidarflow::BucketLists l = lidarflow::bucket_lists(n, buckets, [&](size_t i, int &a, int &b) {
                a = lo[i];
                b = hi[i];
            });
            assert_int_equal(l.start.size(), static_cast<size_t>(buckets) + 1);
            assert_int_equal(l.start.front(), 0);
            assert_int_equal(l.start.back(), l.items.size());
            for (int b = 0; b < buckets; ++b) {
                std::vector<size_t> want;
                for (size_t i = 0; i < n; ++i)
                    if (lo[i] <= b && b <= hi[i]) want.push_back(i);
                const std::vector<size_t> got(l.items.begin() + static_cast<std::ptrdiff_t>(l.begin(b)),
                                              l.items.begin() + static_cast<std::ptrdiff_t>(l.end(b)));
                assert_true(got == want);
            }
        }
    }
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lists_each_bucket_in_item_order),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}

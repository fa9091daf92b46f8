// SPDX-License-Identifier: MIT
// Background interpolation of estimates before scoring (KITTI devkit behaviour) on hand-built
// rows and columns.
#include <vector>
#include "core/error.hpp"
#include "eval/background_fill.hpp"
// cmocka.h defines fail(), which breaks <ios>: include it after every C++ header. Its 1.1.5
// header has no extern "C" of its own, so wrap it here (test_support.hpp's include is then a no-op).
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
extern "C" {
#include <cmocka.h>
}
#include "test_support.hpp"

using namespace lidarflow;

namespace {

DisparityMap rows_of(const std::vector<std::vector<float>> &rows) {
    DisparityMap d(static_cast<int>(rows.size()), static_cast<int>(rows[0].size()));
    for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x) d(y, x) = rows[y][x];
    return d;
}

void expect_row(const DisparityMap &d, int y, const std::vector<float> &want) {
    for (int x = 0; x < d.cols; ++x)
        if (d(y, x) != want[x]) fail_msg("row %d col %d: got %g, want %g", y, x, d(y, x), want[x]);
}


void interior_hole_takes_background(void **) {
    // Holes between 5 and 8 take 5 (the smaller, farther one); between 8 and 3 take 3.
    const DisparityMap d = rows_of({{5, -1, -1, 8, -1, 3}});
    const DisparityMap f = eval::fill_background(d);
    expect_row(f, 0, {5, 5, 5, 8, 3, 3});
    assert_true(d(0, 1) == -1.0f);  // input untouched
}

void row_ends_copy_nearest_valid(void **) {
    const DisparityMap f = eval::fill_background(rows_of({{-1, -1, 7, -1, 9, -1, -1}}));
    expect_row(f, 0, {7, 7, 7, 7, 9, 9, 9});
    // A single valid pixel spreads over the whole row.
    expect_row(eval::fill_background(rows_of({{-1, -1, 4, -1}})), 0, {4, 4, 4, 4});
}

void any_negative_is_a_hole(void **) {
    // -3 and -0.5 are holes like -1; a valid 0 is a real value and wins the minimum.
    expect_row(eval::fill_background(rows_of({{6, -3, -0.5f, 0, -2, 2}})), 0, {6, 0, 0, 0, 0, 2});
}

void invalid_rows_filled_by_column_pass(void **) {
    // Row 0 and row 4 are all-invalid at the image border: copied from rows 1 and 3. Row 2 is
    // all-invalid between valid rows: the devkit leaves it invalid, and so must we.
    const DisparityMap f = eval::fill_background(rows_of({{-1, -1, -1},
                                                          {1, -1, 3},
                                                          {-1, -1, -1},
                                                          {-1, 6, -1},
                                                          {-1, -1, -7}}));
    expect_row(f, 0, {1, 1, 3});
    expect_row(f, 1, {1, 1, 3});
    expect_row(f, 2, {-1, -1, -1});
    expect_row(f, 3, {6, 6, 6});
    expect_row(f, 4, {6, 6, 6});
}

void all_invalid_stays_invalid(void **) {
    const DisparityMap f = eval::fill_background(DisparityMap(4, 5, -2.0f));
    for (int y = 0; y < 4; ++y) expect_row(f, y, {-1, -1, -1, -1, -1});
}

void single_column_image(void **) {
    // Width 1: the row pass sees one pixel per row; only the column pass can fill.
    const DisparityMap f = eval::fill_background(rows_of({{-1}, {2}, {-1}, {5}, {-1}}));
    const float want[] = {2, 2, -1, 5, 5};
    for (int y = 0; y < 5; ++y) assert_true(f(y, 0) == want[y]);
}

void flow_minimum_per_component(void **) {
    FlowField fl = FlowField::zeros(5, 1);
    fl.u(0, 0) = 1;
    fl.v(0, 0) = 5;
    fl.valid(0, 0) = 1;
    fl.u(0, 3) = 4;
    fl.v(0, 3) = -2;
    fl.valid(0, 3) = 255;  // any non-zero is valid
    fl.u(0, 1) = 99;       // garbage at a hole is overwritten
    const FlowField f = eval::fill_background(fl);
    const float wu[] = {1, 1, 1, 4, 4}, wv[] = {5, -2, -2, -2, -2};
    for (int x = 0; x < 5; ++x) {
        assert_true(f.valid(0, x) == 1);
        if (f.u(0, x) != wu[x] || f.v(0, x) != wv[x])
            fail_msg("x=%d: got (%g, %g), want (%g, %g)", x, f.u(0, x), f.v(0, x), wu[x], wv[x]);
    }
    assert_true(fl.valid(0, 1) == 0);  // input untouched
}

void flow_unfilled_rows_are_zero_and_invalid(void **) {
    FlowField fl = FlowField::zeros(2, 4);
    fl.u.setTo(42.0f);  // garbage everywhere the mask says invalid
    fl.v.setTo(-42.0f);
    fl.u(1, 0) = 3;
    fl.v(1, 0) = 4;
    fl.valid(1, 0) = 1;
    fl.u(3, 1) = -1;
    fl.v(3, 1) = 2;
    fl.valid(3, 1) = 1;
    const FlowField f = eval::fill_background(fl);
    // Row 0 copies row 1 (column pass), row 1 extends (3, 4), row 2 stays invalid as (0, 0),
    // row 3 extends (-1, 2).
    const float wu[4][2] = {{3, 3}, {3, 3}, {0, 0}, {-1, -1}}, wv[4][2] = {{4, 4}, {4, 4}, {0, 0}, {2, 2}};
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 2; ++x) {
            assert_true(f.valid(y, x) == (y == 2 ? 0 : 1));
            if (f.u(y, x) != wu[y][x] || f.v(y, x) != wv[y][x])
                fail_msg("(%d,%d): got (%g, %g)", x, y, f.u(y, x), f.v(y, x));
        }
}

void bad_input_throws(void **) {
    assert_true(test::error_code_of([] { eval::fill_background(DisparityMap()); }) == ErrorCode::InvalidArgument);
    assert_true(test::error_code_of([] { eval::fill_background(FlowField{}); }) == ErrorCode::InvalidArgument);
    FlowField fl = FlowField::zeros(4, 3);
    fl.valid = cv::Mat1b::zeros(3, 5);
    assert_true(test::error_code_of([&] { eval::fill_background(fl); }) == ErrorCode::SizeMismatch);
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(interior_hole_takes_background),
        cmocka_unit_test(row_ends_copy_nearest_valid),
        cmocka_unit_test(any_negative_is_a_hole),
        cmocka_unit_test(invalid_rows_filled_by_column_pass),
        cmocka_unit_test(all_invalid_stays_invalid),
        cmocka_unit_test(single_column_image),
        cmocka_unit_test(flow_minimum_per_component),
        cmocka_unit_test(flow_unfilled_rows_are_zero_and_invalid),
        cmocka_unit_test(bad_input_throws),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}

// SPDX-License-Identifier: MIT
// core/ordered_pool.hpp: jobs of uneven length come back in submission order, run at the same
// time, hand their exceptions to the owner, at most capacity() are in flight, and a submit that
// runs out of memory submits nothing.
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <thread>

#include "core/error.hpp"
#include "core/ordered_pool.hpp"
#include "test_support.hpp"

using lidarflow::OrderedPool;

namespace {
// The calling thread's allocations to let through before one fails (-1: none fails).
thread_local int allocations_before_failure = -1;
}  // namespace

void *operator new(std::size_t n) {
    if (allocations_before_failure >= 0 && allocations_before_failure-- == 0) throw std::bad_alloc();
    if (void *p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void *p) noexcept { std::free(p); }
void operator delete(void *p, std::size_t) noexcept { std::free(p); }

namespace {

void results_in_submission_order(void **) {
    OrderedPool<int> pool(3);
    std::atomic<int> running{0}, most{0};
    int next = 0;
    for (int k = 0; k < 12; ++k) {
        pool.submit([k, &running, &most] {
            const int now = ++running;
            for (int m = most.load(); now > m && !most.compare_exchange_weak(m, now);) {
            }
            // Later jobs are shorter: without the order they would come back first.
            std::this_thread::sleep_for(std::chrono::milliseconds(2 * (3 - k % 3)));
            --running;
            return k;
        });
        if (pool.full()) assert_int_equal(pool.take_oldest().get(), next++);
    }
    while (pool.in_flight() > 0) assert_int_equal(pool.take_oldest().get(), next++);
    assert_int_equal(next, 12);
    assert_true(most.load() >= 2);  // they overlapped
    assert_true(most.load() <= 3);
}

void errors_reach_the_owner_in_their_turn(void **) {
    OrderedPool<int> pool(2);
    pool.submit([]() -> int { throw lidarflow::Error(lidarflow::ErrorCode::InvalidArgument, "bad pair"); });
    pool.submit([] { return 7; });
    bool thrown = false;
    try {
        pool.take_oldest().get();
    } catch (const lidarflow::Error &e) {
        thrown = e.code() == lidarflow::ErrorCode::InvalidArgument;
    }
    assert_true(thrown);
    assert_int_equal(pool.take_oldest().get(), 7);
}

void refuses_beyond_capacity_and_drains(void **) {
    OrderedPool<int> pool(1);
    std::atomic<int> done{0};
    pool.submit([&done] {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        return ++done;
    });
    bool refused = false;
    try {
        pool.submit([] { return 0; });
    } catch (const lidarflow::Error &e) {
        refused = e.code() == lidarflow::ErrorCode::BadState;
    }
    assert_true(refused);
    pool.drain();  // waits for the job, drops its result
    assert_int_equal(done.load(), 1);
    assert_int_equal(pool.in_flight(), 0);
    bool empty = false;
    try {
        pool.take_oldest();
    } catch (const lidarflow::Error &e) {
        empty = e.code() == lidarflow::ErrorCode::BadState;
    }
    assert_true(empty);
    bool bad_size = false;
    try {
        OrderedPool<int> none(0);
    } catch (const lidarflow::Error &e) {
        bad_size = e.code() == lidarflow::ErrorCode::InvalidArgument;
    }
    assert_true(bad_size);
}

// Every allocation of every submit fails in turn (the deques grow by blocks, so 100 submits
// meet their block allocations too): the pool then counts no job that will never run, and every
// job submitted comes back once, in order.
void a_submit_out_of_memory_submits_nothing(void **) {
    OrderedPool<int> pool(8);
    int next = 0, failures = 0;
    for (int k = 0; k < 100; ++k) {
        if (pool.full()) assert_int_equal(pool.take_oldest().get(), next++);
        for (int fail_at = 0;; ++fail_at) {
            const size_t before = pool.in_flight();
            allocations_before_failure = fail_at;
            bool out_of_memory = false;
            try {
                pool.submit([k] { return k; });
            } catch (const std::bad_alloc &) {
                out_of_memory = true;
            }
            allocations_before_failure = -1;
            if (!out_of_memory) break;
            ++failures;
            assert_int_equal(pool.in_flight(), before);
        }
    }
    while (pool.in_flight() > 0) assert_int_equal(pool.take_oldest().get(), next++);
    assert_int_equal(next, 100);
    assert_true(failures >= 100);  // at least the shared state of each job's future
}

}  // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(results_in_submission_order),
        cmocka_unit_test(errors_reach_the_owner_in_their_turn),
        cmocka_unit_test(refuses_beyond_capacity_and_drains),
        cmocka_unit_test(a_submit_out_of_memory_submits_nothing),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}

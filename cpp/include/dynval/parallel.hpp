// Work split over threads by independent items (joints, columns): each item's sums are formed by
// one thread in the same order as without threads, so results do not depend on the thread count.
#pragma once

#include "types.hpp"

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <thread>
#include <vector>

namespace dynval {
namespace detail {

/// Threads for `items` independent items of `work` multiply-adds in all: the machine's hardware
/// threads, or DYNVAL_NUM_THREADS when set to a positive integer; one below about 20 ms of work,
/// where starting a thread is not worth it.
inline Index worker_count(Index items, double work) {
    constexpr double min_work = 1e8;
    if (items < 2 || work < min_work) return 1;
    long long wanted = static_cast<long long>(std::thread::hardware_concurrency());
    if (const char* env = std::getenv("DYNVAL_NUM_THREADS")) {
        char* end = nullptr;
        const long long v = std::strtoll(env, &end, 10);
        if (end != env && *end == '\0' && v > 0) wanted = v;
    }
    return std::max<Index>(1, std::min<Index>(items, static_cast<Index>(wanted)));
}

/// f(w, begin, end) for the w-th of `workers` contiguous ranges of [0, items), the first on this
/// thread. An exception in any range is rethrown here after every thread has finished.
template <class F>
void for_ranges(Index items, Index workers, F&& f) {
    if (workers <= 1) {
        f(Index{0}, Index{0}, items);
        return;
    }
    std::vector<std::exception_ptr> errors(static_cast<std::size_t>(workers));
    const auto run = [&](Index w) {
        try {
            f(w, items * w / workers, items * (w + 1) / workers);
        } catch (...) {
            errors[static_cast<std::size_t>(w)] = std::current_exception();
        }
    };
    std::vector<std::thread> threads;
    threads.reserve(static_cast<std::size_t>(workers - 1));
    for (Index w = 1; w < workers; ++w) threads.emplace_back(run, w);
    run(0);
    for (auto& t : threads) t.join();
    for (const auto& e : errors)
        if (e) std::rethrow_exception(e);
}

}  // namespace detail
}  // namespace dynval

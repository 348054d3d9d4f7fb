// Work on the two cores a machine running this has at least: each item writes only what is its
// own, so results do not depend on the threads. Progress is reported and cancellation polled on the
// calling thread only.
#pragma once

#include "core/progress.h"

#include <atomic>
#include <cstdlib>
#include <future>
#include <string>
#include <system_error>
#include <vector>

namespace idealize {

// IDEALIZE_THREADS=1 in the environment runs both halves on the calling thread, one after the
// other; the results are the same (tests/test_cli.py compares them).
inline bool one_thread() {
  static const bool one = [] {
    const char* threads = std::getenv("IDEALIZE_THREADS");
    return threads != nullptr && std::string(threads) == "1";
  }();
  return one;
}

// Runs half(0) here and half(1) on a second thread (or here after it when no thread can
// be had, or one_thread()), and waits for both. Should the first throw (cancelled), leaving waits
// for the second.
template <class Half>
void on_two_threads(const Half& half) {
  std::future<void> second;
  try {
    second = std::async(one_thread() ? std::launch::deferred : std::launch::async, half, 1);
  } catch (const std::system_error&) {
    second = std::async(std::launch::deferred, half, 1);
  }
  half(0);
  second.get();
}

// Runs work(i) for each i of `items`, dealing them out in turn: put the largest first. Before each of
// its items the calling thread reports the share done into `progress` (which may throw to cancel).
template <class Work>
void on_two_threads(const std::vector<int>& items, const Work& work, const ProgressSpan& progress) {
  on_two_threads([&](size_t first) {
    for (size_t k = first; k < items.size(); k += 2) {
      if (first == 0) progress.step(static_cast<double>(k) / items.size());
      work(items[k]);
    }
  });
}

// Runs work(i) for each i in [0, count) on two threads, each taking the next item as soon as it is
// free: for items of very uneven cost (a few of them take most of the time). `work` must not throw.
template <class Work>
void on_two_threads_as_free(int count, const Work& work) {
  std::atomic<int> next{0};
  on_two_threads([&](size_t) {
    for (int i = next++; i < count; i = next++) work(i);
  });
}

// The same, both threads taking no further item once `progress` is cancelled; then throws Cancelled.
template <class Work>
void on_two_threads_as_free(int count, const Work& work, const ProgressSpan& progress) {
  std::atomic<int> next{0};
  const auto cancelled = [&] { return progress.progress && progress.progress->cancelled(); };
  on_two_threads([&](size_t) {
    for (int i = next++; i < count && !cancelled(); i = next++) work(i);
  });
  progress.check();
}

// for_each_polled (progress.h) on two threads: blocks of `block` items in turn.
// One block or fewer runs here only: the second thread would have nothing to do (a 4,000-face
// region's denoising started one 68 times for nothing; the time saved was below the noise).
template <class Body>
void for_each_polled_on_two_threads(int count, const ProgressSpan& progress, const Body& body, int block = 1 << 14) {
  if (count <= block) {
    progress.step(0.0);
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  on_two_threads([&](size_t first) {
    for (int begin = static_cast<int>(first) * block; begin < count; begin += 2 * block) {
      if (first == 0) progress.step(static_cast<double>(begin) / count);
      const int end = count - begin > block ? begin + block : count;
      for (int i = begin; i < end; ++i) body(i);
    }
  });
}

}  // namespace idealize

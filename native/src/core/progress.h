// Progress reporting and cancellation for the long computations.
//
// A GUI runs segmentation, identification and B-rep construction in a worker thread and shows a
// progress bar with a Cancel button: the worker reports into a Progress, the GUI thread reads
// fraction() and stage() and may call cancel() at any time. The algorithms poll the flag inside
// their long loops and throw Cancelled, so a cancelled call returns nothing half-done. Reporting
// never changes a result: with or without a Progress the output is the same.
#pragma once

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <string>

namespace idealize {

struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled by the user") {}
};

class Progress {
 public:
  Progress() = default;
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  void check() const {
    if (cancelled()) throw Cancelled();
  }

  // Overall fraction done, 0..1.
  double fraction() const { return fraction_.load(std::memory_order_relaxed); }
  std::string stage() const { return stage_.load(std::memory_order_relaxed); }

  // The part of the overall bar that the next call fills. With `restart` the bar restarts at
  // `start`, so that one Progress can be reused for another run; without, it stays where it is
  // (for a caller that gives the range it split back to its own caller).
  void set_range(double start, double end, bool restart = true) {
    start = std::clamp(start, 0.0, 1.0);
    end = std::clamp(end, start, 1.0);
    start_.store(start, std::memory_order_relaxed);
    end_.store(end, std::memory_order_relaxed);
    if (restart) fraction_.store(start, std::memory_order_relaxed);
  }
  double range_start() const { return start_.load(std::memory_order_relaxed); }
  double range_end() const { return end_.load(std::memory_order_relaxed); }

  // `stage` must be a string literal (it is kept as a pointer, so reading it needs no lock);
  // `fraction` is the part of the current call done, mapped into the range. The overall fraction
  // never decreases.
  void report(const char* stage, double fraction) {
    stage_.store(stage, std::memory_order_relaxed);
    const double start = range_start(), end = range_end();
    const double overall = start + (end - start) * std::clamp(fraction, 0.0, 1.0);
    double current = fraction_.load(std::memory_order_relaxed);
    while (overall > current && !fraction_.compare_exchange_weak(current, overall, std::memory_order_relaxed)) {
    }
  }

 private:
  std::atomic<bool> cancelled_{false};
  std::atomic<double> fraction_{0.0};
  std::atomic<double> start_{0.0}, end_{1.0};
  std::atomic<const char*> stage_{""};
};

// A stretch [start, end] of one call's progress under one stage name, handed to the helpers that
// run the long loops. Default-constructed it reports nothing and never cancels.
struct ProgressSpan {
  Progress* progress = nullptr;
  const char* stage = "";
  double start = 0.0, end = 1.0;

  ProgressSpan() = default;
  ProgressSpan(Progress* p, const char* name, double from = 0.0, double to = 1.0)
      : progress(p), stage(name), start(from), end(to) {}

  // The part [from, to] (fractions of this span) under another name.
  ProgressSpan sub(const char* name, double from, double to) const {
    return {progress, name, start + (end - start) * from, start + (end - start) * to};
  }
  ProgressSpan sub(double from, double to) const { return sub(stage, from, to); }

  // Reports `fraction` (0..1) of this span done, and throws Cancelled when cancelled.
  void step(double fraction) const {
    if (!progress) return;
    progress->check();
    progress->report(stage, start + (end - start) * fraction);
  }
  // Only the cancellation check: cheap enough for every few thousand iterations of a hot loop.
  void check() const {
    if (progress) progress->check();
  }
  // Every `every` iterations (a power of two): the cancellation check, for loops of unknown length.
  void poll(long long i, long long every = 1 << 14) const {
    if (progress && (i & (every - 1)) == 0) progress->check();
  }
  // Every `every` iterations (a power of two), the progress through a loop of `count` items.
  void tick(long long i, long long count, long long every = 1 << 14) const {
    if (progress && (i & (every - 1)) == 0) step(count > 0 ? static_cast<double>(i) / count : 0.0);
  }
};

// Runs body(i) for i = 0 .. count-1 in order, reporting into `progress` and polling it between
// blocks of `block` items: the inner loop holds no check, so hot loops compile as they would
// without progress (a check inside them measurably slowed the denoising passes).
template <class Body>
void for_each_polled(int count, const ProgressSpan& progress, Body&& body, int block = 1 << 14) {
  for (int begin = 0; begin < count; begin += block) {
    progress.step(static_cast<double>(begin) / count);
    const int end = count - begin > block ? begin + block : count;
    for (int i = begin; i < end; ++i) body(i);
  }
}

}  // namespace idealize

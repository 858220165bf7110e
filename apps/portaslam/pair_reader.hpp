// How `portaslam run` reads a dataset's stereo pairs and hands them to the System: ahead of time
// on threads of their own as fast as possible, on the frames' thread when paced like a camera;
// into a ring of the System's input images (read in place by the frontend: pinned host memory on
// cuda) or, with --input copy, as images the System copies on submit.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <future>
#include <vector>

#include "porta/backend.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/system.hpp"

namespace porta::app {

class PairReader {
 public:
  /// A pair read: `input` holds it in the System's input images, or `pair` does (copy).
  struct Slot {
    slam::StereoPair pair;
    slam::StereoInput input;
    double time_s = 0.0;
  };

  /// Pairs first..end-1 of `dataset`, up to `read_ahead` of them read ahead (0: each when asked
  /// for, on the caller's thread). `pinned`: into input images `system` makes, else copied on
  /// submit. `backend` is the System's: the destructor waits until it has read the images.
  PairReader(const slam::StereoDataset& dataset, slam::System& system, Backend& backend, std::size_t first,
             std::size_t end, std::size_t read_ahead, bool pinned);
  ~PairReader();
  PairReader(const PairReader&) = delete;
  PairReader& operator=(const PairReader&) = delete;

  /// The next pair (the dataset's error if it cannot be read); the wait goes to input_wait_ns().
  const Slot& next();
  /// Submits a pair next() gave; its images are in use until tracked() says so.
  void submit(slam::System& system, const Slot& slot) const;
  /// Every pair before `end` has been tracked: their images may take later pairs.
  void tracked(std::size_t end) { tracked_end_ = end; }

  /// How long each next() waited: what reading cost the frames' loop.
  const std::vector<std::int64_t>& input_wait_ns() const { return input_wait_ns_; }
  /// CPU seconds spent reading (decoding, rectifying, filling the input images), on any thread.
  double cpu_s() const { return cpu_s_.load(); }

 private:
  Slot& load(std::size_t i);  // on whichever thread reads pair i
  std::size_t request();      // the next pair to read; std::logic_error if its slot is in use

  const slam::StereoDataset& dataset_;
  Backend& backend_;
  const std::size_t end_, read_ahead_;
  const bool pinned_;
  std::vector<Slot> slots_;  // pair i in slots_[i % size]
  std::size_t next_request_, tracked_end_;
  std::deque<std::future<Slot*>> reads_;
  std::vector<std::int64_t> input_wait_ns_;
  std::atomic<double> cpu_s_{0.0};
};

}  // namespace porta::app

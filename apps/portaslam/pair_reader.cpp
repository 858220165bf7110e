#include "pair_reader.hpp"

#include <chrono>
#include <stdexcept>
#include <string>
#include <utility>

#include "cpu/thread_name.hpp"
#include "porta/slam/elapsed.hpp"
#include "thread_cpu.hpp"

namespace porta::app {

// The ring: while pair i is read, at most read_ahead + 1 pairs are being read and the System's
// frames in flight wait to be tracked, so read_ahead + 2 + in flight slots never meet a pair in
// use (request() checks it all the same).
PairReader::PairReader(const slam::StereoDataset& dataset, slam::System& system, Backend& backend,
                       std::size_t first, std::size_t end, std::size_t read_ahead, bool pinned)
    : dataset_(dataset), backend_(backend), end_(end), read_ahead_(read_ahead), pinned_(pinned),
      slots_(read_ahead + 2 + static_cast<std::size_t>(system.frontend_in_flight())), next_request_(first),
      tracked_end_(first) {
  if (pinned_) {
    for (Slot& slot : slots_) {
      slot.input.left = system.make_input_image();
      slot.input.right = system.make_input_image();
    }
  }
  input_wait_ns_.reserve(end > first ? end - first : 0);
}

PairReader::~PairReader() {
  reads_.clear();  // waits for the reads under way
  // Left early (an exception) with frames in flight: the device is done with the images before
  // they are freed.
  try {
    backend_.synchronize();
  } catch (...) {  // a device error here was reported by the call that met it first
  }
}

PairReader::Slot& PairReader::load(std::size_t i) {
  const double cpu_start = this_thread_cpu_seconds();
  Slot& slot = slots_[i % slots_.size()];
  slot.pair = dataset_.load(i);
  slot.time_s = slot.pair.time_s;
  if (pinned_) {
    slot.input.index = slot.pair.index;
    slot.input.time_s = slot.pair.time_s;
    slot.input.left.assign(slot.pair.left.view());
    slot.input.right.assign(slot.pair.right.view());
    slot.pair = {};  // the input images hold it now
  }
  cpu_s_.fetch_add(this_thread_cpu_seconds() - cpu_start);
  return slot;
}

std::size_t PairReader::request() {
  const std::size_t i = next_request_++;
  if (i >= tracked_end_ + slots_.size())
    throw std::logic_error("run: pair " + std::to_string(i) + " read before pair " +
                           std::to_string(i - slots_.size()) + " was tracked");
  return i;
}

const PairReader::Slot& PairReader::next() {
  const auto wait_start = std::chrono::steady_clock::now();
  if (read_ahead_ == 0) {
    const Slot& slot = load(request());
    input_wait_ns_.push_back(slam::elapsed_ns(wait_start));
    return slot;
  }
  while (reads_.size() < read_ahead_ + 1 && next_request_ < end_) {
    const std::size_t i = request();
    reads_.push_back(std::async(std::launch::async, [this, i] {
      cpu::name_this_thread("porta-reader");
      return &load(i);
    }));
  }
  if (reads_.empty()) throw std::logic_error("run: no pair left to read");
  std::future<Slot*> read = std::move(reads_.front());
  reads_.pop_front();
  const Slot* slot = read.get();
  input_wait_ns_.push_back(slam::elapsed_ns(wait_start));
  return *slot;
}

void PairReader::submit(slam::System& system, const Slot& slot) const {
  if (pinned_) {
    system.submit(slot.input);
  } else {
    system.submit(slot.pair);
  }
}

}  // namespace porta::app

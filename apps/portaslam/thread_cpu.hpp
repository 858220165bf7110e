// CPU time by thread, for `portaslam run`'s report: which of the engine's threads (named by
// cpu::name_this_thread: porta-mapping, porta-loop, porta-cpu, ...) the host CPU goes to.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace porta::app {

/// Every thread of the process now: its name and CPU seconds (user + system) so far. Empty where
/// /proc/self/task cannot be read (not Linux).
struct ThreadCpuSnapshot {
  struct Thread {
    std::string name;
    double cpu_s = 0.0;
  };
  std::map<int, Thread> by_tid;
};
ThreadCpuSnapshot thread_cpu_snapshot();

/// CPU seconds spent between two snapshots by the threads alive at `end`, summed by name (a thread
/// started meanwhile counts from 0), largest first; then "(ended threads)": what the process spent
/// (`process_cpu_s`, from getrusage over the same span) beyond them, in threads that ended meanwhile.
std::vector<std::pair<std::string, double>> thread_cpu_between(const ThreadCpuSnapshot& start,
                                                               const ThreadCpuSnapshot& end, double process_cpu_s);

/// One line for the report: "host CPU by thread (ms per frame): porta-mapping 16.70, ..." and, when
/// `reading_cpu_s` > 0, what decoding the input images took of it (on whichever thread read them).
std::string thread_cpu_text(const std::vector<std::pair<std::string, double>>& by_thread, double reading_cpu_s,
                            double frames);
/// The same as a JSON object: {"by_thread_s": {name: seconds, ...}, "reading_s": seconds}.
std::string thread_cpu_json(const std::vector<std::pair<std::string, double>>& by_thread, double reading_cpu_s);

/// CPU seconds the calling thread has used (CLOCK_THREAD_CPUTIME_ID); 0 where there is no such clock.
double this_thread_cpu_seconds();

}  // namespace porta::app

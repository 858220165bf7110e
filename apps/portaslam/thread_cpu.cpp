#include "thread_cpu.hpp"

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#if defined(__linux__)
#include <unistd.h>
#endif

namespace porta::app {
namespace {

/// utime + stime of /proc/self/task/<tid>/stat in seconds; false when it cannot be read. The name
/// (in parentheses, may hold spaces) is skipped by the last ')'.
bool read_task_cpu(const std::filesystem::path& task, double& seconds) {
#if defined(__linux__)
  std::ifstream in(task / "stat");
  std::string line;
  if (!std::getline(in, line)) return false;
  const std::size_t close = line.rfind(')');
  if (close == std::string::npos) return false;
  std::istringstream fields(line.substr(close + 1));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  // Fields 3 (state) to 13 come first; 14 and 15 are utime and stime, in clock ticks.
  for (int k = 3; k <= 13; ++k) fields >> field;
  if (!(fields >> utime >> stime)) return false;
  const long ticks = ::sysconf(_SC_CLK_TCK);
  if (ticks <= 0) return false;
  seconds = static_cast<double>(utime + stime) / static_cast<double>(ticks);
  return true;
#else
  (void)task;
  (void)seconds;
  return false;
#endif
}

}  // namespace

ThreadCpuSnapshot thread_cpu_snapshot() {
  ThreadCpuSnapshot snapshot;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task", error)) {
    int tid = 0;
    try {
      tid = std::stoi(entry.path().filename().string());
    } catch (const std::exception&) {
      continue;
    }
    ThreadCpuSnapshot::Thread thread;
    std::ifstream comm(entry.path() / "comm");
    if (!std::getline(comm, thread.name) || !read_task_cpu(entry.path(), thread.cpu_s)) continue;  // ended meanwhile
    snapshot.by_tid[tid] = thread;
  }
  return snapshot;
}

std::vector<std::pair<std::string, double>> thread_cpu_between(const ThreadCpuSnapshot& start,
                                                               const ThreadCpuSnapshot& end, double process_cpu_s) {
  std::map<std::string, double> by_name;
  double alive = 0.0;
  for (const auto& [tid, thread] : end.by_tid) {
    const auto before = start.by_tid.find(tid);
    const double spent = std::max(0.0, thread.cpu_s - (before == start.by_tid.end() ? 0.0 : before->second.cpu_s));
    by_name[thread.name] += spent;
    alive += spent;
  }
  std::vector<std::pair<std::string, double>> out(by_name.begin(), by_name.end());
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  if (!end.by_tid.empty()) out.emplace_back("(ended threads)", std::max(0.0, process_cpu_s - alive));
  return out;
}

std::string thread_cpu_text(const std::vector<std::pair<std::string, double>>& by_thread, double reading_cpu_s,
                            double frames) {
  if (by_thread.empty()) return "";
  const double per_frame_ms = 1000.0 / std::max(frames, 1.0);
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(2);
  out << "host CPU by thread (ms per frame):";
  const char* separator = " ";
  for (const auto& [name, seconds] : by_thread) {
    out << separator << name << " " << seconds * per_frame_ms;
    separator = ", ";
  }
  if (reading_cpu_s > 0.0) out << "; of all this, reading the images " << reading_cpu_s * per_frame_ms;
  return out.str();
}

std::string thread_cpu_json(const std::vector<std::pair<std::string, double>>& by_thread, double reading_cpu_s) {
  std::ostringstream out;
  out << "{\"by_thread_s\": {";
  for (std::size_t k = 0; k < by_thread.size(); ++k) {
    std::string name;
    for (const char c : by_thread[k].first) {
      if (c == '"' || c == '\\') name += '\\';
      if (static_cast<unsigned char>(c) >= 0x20) name += c;
    }
    out << (k == 0 ? "" : ", ") << "\"" << name << "\": " << by_thread[k].second;
  }
  out << "}, \"reading_s\": " << reading_cpu_s << "}";
  return out.str();
}

double this_thread_cpu_seconds() {
#if defined(CLOCK_THREAD_CPUTIME_ID)
  timespec t{};
  if (::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t) != 0) return 0.0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
#else
  return 0.0;
#endif
}

}  // namespace porta::app

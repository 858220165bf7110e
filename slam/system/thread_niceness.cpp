#include "thread_niceness.hpp"

#if defined(__linux__)
#include <sys/resource.h>
#include <unistd.h>
#endif

namespace porta::slam::detail {

void set_thread_nice(int nice) {
#if defined(__linux__)
  // On Linux a nice value belongs to the thread (its kernel task), not the process.
  if (nice > 0) (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), nice);
#else
  (void)nice;
#endif
}

}  // namespace porta::slam::detail

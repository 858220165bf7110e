// Names the calling thread, so that profilers, `top -H` and `portaslam run`'s CPU by thread tell
// the engine's threads apart (a new thread inherits its creator's name otherwise).
#pragma once

#if defined(__linux__)
#include <pthread.h>
#endif

namespace porta::cpu {

/// Linux: the calling thread's name (at most 15 characters are kept; a longer name is cut, a null
/// one ignored). Elsewhere: nothing.
inline void name_this_thread(const char* name) {
#if defined(__linux__)
  if (name == nullptr) return;
  char kept[16] = {};
  for (int i = 0; i < 15 && name[i] != '\0'; ++i) kept[i] = name[i];
  (void)pthread_setname_np(pthread_self(), kept);
#else
  (void)name;
#endif
}

}  // namespace porta::cpu

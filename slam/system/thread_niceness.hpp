// The calling thread's nice value (SlamSettings::mapping_thread_nice, loop_closing_thread_nice).
#pragma once

namespace porta::slam::detail {

/// Linux: sets the calling thread's nice value to `nice` (> 0 lowers its share of a busy core
/// against the frame path's threads; 0 leaves it as it is). Best effort: a refusal leaves the
/// thread as it was. Elsewhere: nothing.
void set_thread_nice(int nice);

}  // namespace porta::slam::detail

// Shared by stereo_match_candidates.comp and stereo_match_finish.comp (§3.9 stereo matching,
// DESIGN.md §3.9, backends/cpu/match_kernels.cpp): the SAD histogram that finds the median.
// A centred 11 x 11 SAD is at most 121 * 510: one fine bin per value, and coarse bins of 256 values
// so that the single invocation finding the median walks few bins. Layout of the histogram scratch
// (uints): fine bins, coarse bins, then the median (as int). Must match match_kernels.cpp.
#define STEREO_SAD_VALUES 61711
#define STEREO_SAD_BLOCKS ((STEREO_SAD_VALUES + 255) / 256)
#define STEREO_HIST_COARSE STEREO_SAD_VALUES
#define STEREO_HIST_MEDIAN (STEREO_SAD_VALUES + STEREO_SAD_BLOCKS)

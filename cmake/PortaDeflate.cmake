# Finds libdeflate (Debian: libdeflate-dev), the whole-buffer DEFLATE decoder that imageio/ reads
# 8-bit gray PNG files with, about three times faster than libpng through zlib. Optional: without
# it every PNG goes through libpng. Result: PortaDeflate_FOUND and the imported target
# porta_libdeflate. -DPORTA_FORCE_NO_LIBDEFLATE=ON builds as if it were absent.
option(PORTA_FORCE_NO_LIBDEFLATE "Read PNG files through libpng only, as if libdeflate were absent" OFF)
set(PortaDeflate_FOUND FALSE)
if(NOT PORTA_FORCE_NO_LIBDEFLATE)
  find_path(PORTA_LIBDEFLATE_INCLUDE_DIR libdeflate.h)
  find_library(PORTA_LIBDEFLATE_LIBRARY deflate)
  if(PORTA_LIBDEFLATE_INCLUDE_DIR AND PORTA_LIBDEFLATE_LIBRARY)
    set(PortaDeflate_FOUND TRUE)
    if(NOT TARGET porta_libdeflate)
      add_library(porta_libdeflate UNKNOWN IMPORTED)
      set_target_properties(porta_libdeflate PROPERTIES IMPORTED_LOCATION "${PORTA_LIBDEFLATE_LIBRARY}"
                                                        INTERFACE_INCLUDE_DIRECTORIES "${PORTA_LIBDEFLATE_INCLUDE_DIR}")
    endif()
  endif()
endif()

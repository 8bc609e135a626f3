# Warning flags (per target, vdbmap_set_warnings(<target>)), warnings as errors and sanitizers.

option(VDBMAP_WERROR "Treat the project's compiler warnings as errors" OFF)
# A list of sanitizers for every target of the build, e.g. -DVDBMAP_SANITIZE="address;undefined".
set(VDBMAP_SANITIZE "" CACHE STRING "Sanitizers to build with (a list: address, undefined, thread, ...)")

if(VDBMAP_SANITIZE)
  list(JOIN VDBMAP_SANITIZE "," _vdbmap_sanitizers)
  add_compile_options(-fsanitize=${_vdbmap_sanitizers} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${_vdbmap_sanitizers})
  if("undefined" IN_LIST VDBMAP_SANITIZE)
    # Every UB report aborts, except alignment, which stays recoverable so that it can be
    # suppressed at run time: oneTBB's concurrent_hash_map (OpenVDB's accessor registry, walked by
    # every Tree destructor) downcasts a sentinel pointer 0x3. cmake/ubsan_suppressions.txt names
    # that header; scripts/sanitize.sh and scripts/fuzz.sh run with
    # UBSAN_OPTIONS=suppressions=<it>:halt_on_error=1, so any other misalignment still aborts.
    add_compile_options(-fsanitize-recover=alignment)
  endif()
endif()

function(vdbmap_set_warnings target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
    if(VDBMAP_WERROR)
      target_compile_options(${target} PRIVATE -Werror)
    endif()
  endif()
endfunction()

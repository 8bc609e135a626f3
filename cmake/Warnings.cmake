# Warning flags (per target, vdbmap_set_warnings(<target>)), warnings as errors and sanitizers.

option(VDBMAP_WERROR "Treat the project's compiler warnings as errors" OFF)
# A list of sanitizers for every target of the build, e.g. -DVDBMAP_SANITIZE="address;undefined".
set(VDBMAP_SANITIZE "" CACHE STRING "Sanitizers to build with (a list: address, undefined, thread, ...)")

if(VDBMAP_SANITIZE)
  list(JOIN VDBMAP_SANITIZE "," _vdbmap_sanitizers)
  add_compile_options(-fsanitize=${_vdbmap_sanitizers} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${_vdbmap_sanitizers})
endif()

function(vdbmap_set_warnings target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
    if(VDBMAP_WERROR)
      target_compile_options(${target} PRIVATE -Werror)
    endif()
  endif()
endfunction()

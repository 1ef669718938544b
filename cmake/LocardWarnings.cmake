# Compiler flags shared by every Locard target (applied through locard_set_flags()).
function(locard_set_flags target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow
                         -Wnon-virtual-dtor -Wconversion-null -Wno-sign-compare)
  # GCC 12 reports false -Wrestrict/-Wstringop-overflow on inlined std::string concatenation
  # at -O3 (GCC bugs 105329, 105651); they are not about our code.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict -Wno-stringop-overflow)
  endif()
  if(LOCARD_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(LOCARD_NATIVE)
    target_compile_options(${target} PRIVATE -march=native)
  endif()
endfunction()

if(LOCARD_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

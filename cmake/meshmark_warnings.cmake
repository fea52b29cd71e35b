# SPDX-License-Identifier: MIT
# -Wnull-dereference is left out: GCC 12 reports it at -O3 inside Eigen's inlined templates
# (false positives in system headers that -isystem cannot silence, since the warning comes
# from the optimizer after inlining).
function(meshmark_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion -Wold-style-cast
    -Wnon-virtual-dtor -Woverloaded-virtual -Wimplicit-fallthrough)
  if(MESHMARK_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Deterministic floating point: no FMA contraction, no fast-math; Eigen single-threaded
# (our own loops parallelize over row blocks with a fixed reduction order).
function(meshmark_set_fp_options target)
  target_compile_options(${target} PRIVATE -ffp-contract=off)
  target_compile_definitions(${target} PUBLIC EIGEN_DONT_PARALLELIZE)
endfunction()

# SPDX-License-Identifier: MIT
function(meshmark_set_sanitizers target)
  if(MESHMARK_SANITIZE)
    string(REPLACE ";" "," list "${MESHMARK_SANITIZE}")
    target_compile_options(${target} PUBLIC -fsanitize=${list} -fno-omit-frame-pointer -fno-sanitize-recover=all)
    target_link_options(${target} PUBLIC -fsanitize=${list})
  endif()
endfunction()

// SPDX-License-Identifier: MIT
// Must NOT compile: watermark does not depend on attacks, so its include paths do not reach
// attacks' headers (CMakeLists.txt, meshmark_module_view). The test
// layering.a_module_cannot_include_a_module_it_does_not_depend_on builds this file as part of
// watermark and expects the compiler to say the header does not exist.
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/watermark/decision.h"

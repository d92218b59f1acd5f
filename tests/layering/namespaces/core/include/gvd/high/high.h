#pragma once
#include "gvd/low/low.h"

namespace gvd {
class Vec3;
}

namespace gvd {
inline int high() { return 2; }
}  // namespace gvd

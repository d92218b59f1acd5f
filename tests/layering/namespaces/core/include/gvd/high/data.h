#pragma once
#include "gvd/low/low.h"

namespace gvd::high {
struct Data {
  int value = 0;
};
}  // namespace gvd::high

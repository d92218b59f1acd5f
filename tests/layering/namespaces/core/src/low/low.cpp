#include "gvd/low/low.h"

namespace gvd::low {

using namespace gvd::high;

}  // namespace gvd::low

#include "gvd/low/low.h"
#include "gvd/high/high.h"
#include <vector>

#include "gvd/low/low.h"

#include <vector>

#include "gvd/high/high.h"

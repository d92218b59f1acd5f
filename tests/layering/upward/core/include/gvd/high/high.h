#pragma once
#include "gvd/low/low.h"

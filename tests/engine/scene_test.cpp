// Whole scenes with closed-form solutions (shared/reference/analytic.md, cases 10-14) and the hard
// cases: the solver must stay finite, sane and right.
#include "radiosity/solver.h"

#include <gtest/gtest.h>

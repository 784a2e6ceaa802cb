// Umbrella header of the engine-free solver core.
#pragma once
#include "core/chain.hpp"
#include "core/goal.hpp"
#include "core/kinematics.hpp"
#include "core/options.hpp"
#include "core/result.hpp"
#include "core/solve.hpp"
#include "core/span.hpp"
#include "core/workspace.hpp"

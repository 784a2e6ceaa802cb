// Umbrella header of the engine-free solver core.
#pragma once
#include "ikchain/chain.hpp"
#include "ikchain/goal.hpp"
#include "ikchain/kinematics.hpp"
#include "ikchain/options.hpp"
#include "ikchain/result.hpp"
#include "ikchain/solve.hpp"
#include "ikchain/span.hpp"
#include "ikchain/workspace.hpp"

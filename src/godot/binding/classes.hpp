// Typed engine classes (Object, Node, Node3D, Skeleton3D, ...): generated from extension_api.json
// by tools/gen_engine_api.py for the methods listed in src/godot/engine_api.txt.
#pragma once

#include "binding/engine.hpp"
#include "engine_classes.gen.hpp"

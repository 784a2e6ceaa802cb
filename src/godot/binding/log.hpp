// Engine-side error reporting (shows in the Output panel / stderr as "ERROR: ...").
#pragma once

#include "binding/interface.hpp"

namespace ikchain::gdx {

inline void print_error(const char* message, const char* function, const char* file, int line) {
  if (gde.print_error != nullptr) gde.print_error(message, function, file, line, /*p_editor_notify=*/1);
}

inline void print_warning(const char* message, const char* function, const char* file, int line) {
  if (gde.print_warning != nullptr) gde.print_warning(message, function, file, line, /*p_editor_notify=*/1);
}

}  // namespace ikchain::gdx

#define IKCHAIN_PRINT_ERROR(msg) ::ikchain::gdx::print_error((msg), __func__, __FILE__, __LINE__)
#define IKCHAIN_PRINT_WARNING(msg) ::ikchain::gdx::print_warning((msg), __func__, __FILE__, __LINE__)

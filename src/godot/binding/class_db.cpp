#include "binding/class_db.hpp"

#include <string>

namespace ikchain::gdx {

void MethodRecordBase::report_bad_argument(int32_t index, GDExtensionVariantType expected,
                                           GDExtensionVariantType got) const {
  String expected_name, got_name;
  gde.variant_get_type_name(expected, expected_name.ptr());
  gde.variant_get_type_name(got, got_name.ptr());
  const std::string arg = size_t(index) < arg_names.size() ? arg_names[size_t(index)] : std::to_string(index + 1);
  const std::string message = class_name + "." + method_name + ": argument '" + arg + "' must be " +
                              expected_name.utf8() + ", got " + got_name.utf8() + "; the call was ignored.";
  IKCHAIN_PRINT_ERROR(message.c_str());
}

}  // namespace ikchain::gdx

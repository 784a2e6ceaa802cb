// The GDExtension C interface functions we use, fetched by name through get_proc_address at
// library initialization. Every name is the current (suffixed) version in Godot 4.6.
#pragma once

#include <gdextension_interface.h>

namespace ikchain::gdx {

// X(member, interface name, function-pointer type)
#define IKCHAIN_GDX_INTERFACE_FUNCTIONS(X)                                                              \
  X(get_godot_version2, "get_godot_version2", GDExtensionInterfaceGetGodotVersion2)                      \
  X(mem_alloc2, "mem_alloc2", GDExtensionInterfaceMemAlloc2)                                              \
  X(mem_free2, "mem_free2", GDExtensionInterfaceMemFree2)                                                 \
  X(print_error, "print_error", GDExtensionInterfacePrintError)                                           \
  X(print_warning, "print_warning", GDExtensionInterfacePrintWarning)                                     \
  X(variant_new_copy, "variant_new_copy", GDExtensionInterfaceVariantNewCopy)                             \
  X(variant_new_nil, "variant_new_nil", GDExtensionInterfaceVariantNewNil)                                \
  X(variant_destroy, "variant_destroy", GDExtensionInterfaceVariantDestroy)                               \
  X(variant_get_type, "variant_get_type", GDExtensionInterfaceVariantGetType)                             \
  X(get_variant_from_type_constructor, "get_variant_from_type_constructor",                              \
    GDExtensionInterfaceGetVariantFromTypeConstructor)                                                   \
  X(get_variant_to_type_constructor, "get_variant_to_type_constructor",                                  \
    GDExtensionInterfaceGetVariantToTypeConstructor)                                                     \
  X(variant_get_ptr_constructor, "variant_get_ptr_constructor", GDExtensionInterfaceVariantGetPtrConstructor) \
  X(variant_get_ptr_destructor, "variant_get_ptr_destructor", GDExtensionInterfaceVariantGetPtrDestructor) \
  X(variant_get_ptr_builtin_method, "variant_get_ptr_builtin_method",                                    \
    GDExtensionInterfaceVariantGetPtrBuiltinMethod)                                                      \
  X(string_new_with_utf8_chars_and_len2, "string_new_with_utf8_chars_and_len2",                          \
    GDExtensionInterfaceStringNewWithUtf8CharsAndLen2)                                                   \
  X(string_to_utf8_chars, "string_to_utf8_chars", GDExtensionInterfaceStringToUtf8Chars)                 \
  X(string_name_new_with_utf8_chars_and_len, "string_name_new_with_utf8_chars_and_len",                  \
    GDExtensionInterfaceStringNameNewWithUtf8CharsAndLen)                                                \
  X(packed_string_array_operator_index, "packed_string_array_operator_index",                            \
    GDExtensionInterfacePackedStringArrayOperatorIndex)                                                  \
  X(dictionary_operator_index, "dictionary_operator_index", GDExtensionInterfaceDictionaryOperatorIndex) \
  X(array_operator_index_const, "array_operator_index_const", GDExtensionInterfaceArrayOperatorIndexConst) \
  X(packed_int32_array_operator_index_const, "packed_int32_array_operator_index_const",                  \
    GDExtensionInterfacePackedInt32ArrayOperatorIndexConst)                                              \
  X(object_get_instance_binding, "object_get_instance_binding", GDExtensionInterfaceObjectGetInstanceBinding) \
  X(classdb_register_extension_class_property_group, "classdb_register_extension_class_property_group",  \
    GDExtensionInterfaceClassdbRegisterExtensionClassPropertyGroup)                                      \
  X(variant_get_type_name, "variant_get_type_name", GDExtensionInterfaceVariantGetTypeName)              \
  X(classdb_register_extension_class_signal, "classdb_register_extension_class_signal",                  \
    GDExtensionInterfaceClassdbRegisterExtensionClassSignal)                                             \
  X(object_method_bind_ptrcall, "object_method_bind_ptrcall", GDExtensionInterfaceObjectMethodBindPtrcall) \
  X(object_set_instance, "object_set_instance", GDExtensionInterfaceObjectSetInstance)                   \
  X(object_set_instance_binding, "object_set_instance_binding", GDExtensionInterfaceObjectSetInstanceBinding) \
  X(object_cast_to, "object_cast_to", GDExtensionInterfaceObjectCastTo)                                  \
  X(object_get_instance_id, "object_get_instance_id", GDExtensionInterfaceObjectGetInstanceId)           \
  X(object_get_instance_from_id, "object_get_instance_from_id", GDExtensionInterfaceObjectGetInstanceFromId) \
  X(classdb_construct_object2, "classdb_construct_object2", GDExtensionInterfaceClassdbConstructObject2) \
  X(classdb_get_method_bind, "classdb_get_method_bind", GDExtensionInterfaceClassdbGetMethodBind)        \
  X(classdb_get_class_tag, "classdb_get_class_tag", GDExtensionInterfaceClassdbGetClassTag)              \
  X(classdb_register_extension_class5, "classdb_register_extension_class5",                              \
    GDExtensionInterfaceClassdbRegisterExtensionClass5)                                                  \
  X(classdb_register_extension_class_method, "classdb_register_extension_class_method",                  \
    GDExtensionInterfaceClassdbRegisterExtensionClassMethod)                                             \
  X(classdb_register_extension_class_integer_constant, "classdb_register_extension_class_integer_constant", \
    GDExtensionInterfaceClassdbRegisterExtensionClassIntegerConstant)                                    \
  X(classdb_register_extension_class_property, "classdb_register_extension_class_property",              \
    GDExtensionInterfaceClassdbRegisterExtensionClassProperty)                                           \
  X(classdb_unregister_extension_class, "classdb_unregister_extension_class",                            \
    GDExtensionInterfaceClassdbUnregisterExtensionClass)

struct Interface {
#define IKCHAIN_GDX_DECLARE(member, name, type) type member = nullptr;
  IKCHAIN_GDX_INTERFACE_FUNCTIONS(IKCHAIN_GDX_DECLARE)
#undef IKCHAIN_GDX_DECLARE
  GDExtensionClassLibraryPtr library = nullptr;
};

// Function pointers only (no engine objects): filled once by load_interface(), read everywhere.
extern Interface gde;

// Fetches every function; returns false (after printing the missing name) if one is absent.
bool load_interface(GDExtensionInterfaceGetProcAddress get_proc_address, GDExtensionClassLibraryPtr library);

}  // namespace ikchain::gdx

#include "editor_help.hpp"

#include "binding/log.hpp"
#include "class_docs.gen.hpp"

namespace ikchain::godot {

void load_class_docs(GDExtensionInterfaceGetProcAddress get_proc_address) {
  // Fetched here, not in the binding's table: a missing help loader must not stop the library
  // from loading, only leave the help pages empty. (The header's typedef really says "Extensions".)
  const auto load_xml = reinterpret_cast<GDExtensionsInterfaceEditorHelpLoadXmlFromUtf8CharsAndLen>(
      get_proc_address("editor_help_load_xml_from_utf8_chars_and_len"));
  if (load_xml == nullptr) {
    IKCHAIN_PRINT_ERROR("IKChain: this engine has no editor_help_load_xml_from_utf8_chars_and_len (Godot < 4.3?); "
                        "the IKChain class reference is not shown in the editor help.");
    return;
  }
  for (const class_docs::ClassDoc& doc : class_docs::kClassDocs) {
    load_xml(doc.xml, static_cast<GDExtensionInt>(doc.size));
  }
}

}  // namespace ikchain::godot

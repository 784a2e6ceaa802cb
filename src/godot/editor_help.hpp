// The class reference (godot_project/addons/ikchain/doc_classes/*.xml) in the editor's help.
#pragma once

#include <gdextension_interface.h>

namespace ikchain::godot {

// Hands every embedded class XML to the editor help. Call at the EDITOR initialization level
// (the function exists in every 4.3+ build; in export templates it does nothing). The XML is
// compiled in (tools/class_docs.py generates the header), never read from disk.
void load_class_docs(GDExtensionInterfaceGetProcAddress get_proc_address);

}  // namespace ikchain::godot

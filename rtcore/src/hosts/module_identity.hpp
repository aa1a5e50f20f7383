// module_identity.hpp -- what makes a module file "the same module" across a hot reload.
//
// A module is kept (same instance, same state) when what it loads is unchanged: the SHA-256 over
// its ELF file's loadable sections (name, address, size, flags and content), except two that
// change with every rebuild without changing the code: the layout stamp `.indurop_layout` (the
// hash of the layout it was built against, written by <indurop/generated.h>) and the build id.
// So a module rebuilt against a layout that only gained variables keeps running; debug
// information does not count either.  A file that is not ELF is identified by its whole content.
#pragma once

#include <indurop/result.hpp>

#include <filesystem>
#include <string>

namespace irp::hosts {

struct ModuleIdentity {
    std::string code;    // SHA-256 of the loadable sections, 64 hex digits
    std::string layout;  // the stamp's content: the layout hash it was built against ("" = none)
};

Result<ModuleIdentity> identify(const std::filesystem::path &file);

}  // namespace irp::hosts

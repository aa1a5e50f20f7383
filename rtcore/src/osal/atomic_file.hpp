// atomic_file.hpp -- a file replaced whole or not at all, also across a power loss: the new bytes
// go to <file>.tmp, which is fsync'ed and renamed over <file>, then the folder is fsync'ed.  A
// reader of <file> finds the old content or the new one, never a mix.  Used by the retain store
// (docs/retain.md) and the crash records' exclusions (docs/supervision.md).
#pragma once

#include <indurop/result.hpp>

#include <filesystem>
#include <functional>
#include <string_view>

namespace irp::osal {

// `before_rename` runs once the new file is written and synced, before the rename (a test pauses
// there to stop irpd in the middle of a write).  The Error names the file and the failing call.
Status writeAtomically(const std::filesystem::path &file, std::string_view bytes,
                       const std::function<void()> &before_rename = {});

}  // namespace irp::osal

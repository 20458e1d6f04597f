#pragma once
// What the machine has: the jobs that must hold a whole input or result in memory (a record,
// a compensated command) say before they start how much they will take, and refuse what the
// machine cannot hold instead of ending in std::bad_alloc.
#include <cstdint>
#include <string>

namespace amctl {

/// MemAvailable of /proc/meminfo in bytes; 0 when it cannot be read (no bound is applied then).
[[nodiscard]] std::uint64_t available_memory_bytes();

/// "1.2 GiB", "350 MiB", "12 KiB".
[[nodiscard]] std::string memory_text(std::uint64_t bytes);

}  // namespace amctl

#pragma once
// Process-wide allocator setting for a live robot (or a benchmark) that registers scans in a loop.

namespace hazmap {

/// Asks glibc's malloc to keep freed memory for reuse instead of returning it to the system
/// (blocks up to 32 MiB come from the heap, and the heap is trimmed only above 1 GiB). Every
/// frame allocates and frees the same few megabytes (voxel tables, correspondences); by default
/// glibc serves blocks over 128 KiB with fresh mmap()s and unmaps them on free, so each frame
/// pays a page fault per 4 KiB touched. On the virtual machines we measured on a page fault costs
/// microseconds, which made those faults the largest cost of a frame (docs/measurements.md). Resident
/// memory then stays at its peak instead of shrinking between frames. Call once at start-up,
/// before threads are started; a no-op returning false where glibc's mallopt is unavailable or
/// not in charge (AddressSanitizer brings its own allocator).
bool retainFreedMemory();

/// Gives the system back the free pages the allocator holds (glibc's malloc_trim(0)). With
/// retainFreedMemory() resident memory stays at its peak, and on a long mission that peak creeps
/// up: growing lists leave their old blocks behind, a save's map is freed in the middle of the
/// heap (issue 33: 47 of 133 MiB free but resident after 11 minutes of `hazmap live`). The next
/// frame faults its scratch pages in once more. False where glibc's malloc is not in charge.
bool releaseFreedMemory();

}  // namespace hazmap

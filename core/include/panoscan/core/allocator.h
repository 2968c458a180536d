// Process-wide settings of glibc's allocator for PanoScan's programs (the panoscan command and the
// benchmarks call it first thing in main).
#pragma once

namespace panoscan {

// Keeps freed blocks of up to 32 MB in the process for reuse instead of returning them to the
// kernel. Every frame a stage reads allocates a few megabytes (decoded PNGs, images, ORB's
// pyramid) and frees them again; with glibc's defaults each of these blocks was mapped and unmapped
// (or trimmed off the heap) per frame, and touching fresh pages faults: on the 2-core VM that made
// recon track's feature extraction take 8.2 ms per 640x480 frame instead of 3.9 ms. The blocks now
// stay mapped, so the process's resident memory is its peak working set rather than what it uses at
// the moment (at most 16 MB more per heap). Blocks above 32 MB (the panorama's measurement sets)
// are still mapped and unmapped as before. Returns false if glibc refused a setting (other C
// libraries: a no-op returning false).
bool keep_freed_memory_for_reuse();

}  // namespace panoscan

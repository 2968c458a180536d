// How PanoScan's programs (the panoscan command, the benchmarks) set up their process before any
// work: settings that only take effect when the process starts with them, and the allocator's.
#pragma once

#include <string>

#include "panoscan/core/start_up.h"  // add_start_up_settings and its parts

namespace panoscan {

// Called first thing in main(), before any thread starts. Re-executes the program once
// (execv("/proc/self/exe", argv): the same arguments, descriptors and process id) when the
// environment lacks a setting that is read only at start-up, after adding:
//  - OMP_WAIT_POLICY=PASSIVE: Open3D's OpenMP threads spin while idle and starved oneTBB's on 2
//    cores (~40x slower TSDF integration, 7x slower RGB-D odometry); libgomp reads the policy when
//    it is loaded, before main.
//  - glibc.malloc.hugetlb=1 in GLIBC_TUNABLES (huge_page_heap_tunables): glibc then backs its
//    heaps with transparent huge pages. With 4 KB pages, every fresh page of the frames, point
//    clouds and kd-trees a stage allocates costs a page fault on its first touch (5-7 us each on
//    the 2-core VM): recon scene on the whole office took 2.0 million faults, and 62 thousand with
//    huge pages (88 -> 69 s, peak memory 1.98 -> 1.94 GB, the same cloud bit for bit).
// A user's own setting of either is kept. The panoscan command's launcher (app/launcher.cpp) adds
// both before the program is loaded, which then need not re-execute (its 211 shared libraries
// would be loaded twice, 0.16 s of every call). If the re-execution fails, the program carries on
// without them; under valgrind it is not tried (its /proc/self/exe is not the program). Then
// applies keep_freed_memory_for_reuse (allocator.h).
void set_up_process(char** argv);

}  // namespace panoscan

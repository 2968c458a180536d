// How PanoScan's programs (the panoscan command, the benchmarks) set up their process before any
// work: settings that only take effect when the process starts with them, and the allocator's.
#pragma once

#include <string>

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
// A user's own setting of either is kept. If the re-execution fails, the program carries on
// without them; under valgrind it is not tried (its /proc/self/exe is not the program). Then
// applies keep_freed_memory_for_reuse (allocator.h).
void set_up_process(char** argv);

// The value GLIBC_TUNABLES needs for a huge-page heap, given its current value (nullptr = unset):
// the current tunables with glibc.malloc.hugetlb=1 appended, or "" when nothing is to change (a
// glibc.malloc.hugetlb setting is there already: the re-executed process, or the user's own,
// e.g. hugetlb=0 to switch it off).
std::string huge_page_heap_tunables(const char* current);

// Whether this process can use a huge-page heap: glibc 2.35 or newer (older ones ignore the
// tunable) on a kernel whose transparent huge pages are "always" or "madvise" (not "never").
bool huge_page_heap_supported();

}  // namespace panoscan

// The settings a PanoScan process needs from its very start (read by glibc's loader and by libgomp
// before main runs), kept apart from the rest of core so that the panoscan command's launcher
// (app/launcher.cpp) links nothing else. core/process.h says why each is needed.
#pragma once

#include <string>

namespace panoscan {

// Adds to the environment the start-up settings it lacks: OMP_WAIT_POLICY=PASSIVE, and where
// huge_page_heap_supported, glibc.malloc.hugetlb=1 in GLIBC_TUNABLES. A user's own setting of
// either is kept. Returns whether anything was added (then only a new program image gets them).
bool add_start_up_settings();

// The value GLIBC_TUNABLES needs for a huge-page heap, given its current value (nullptr = unset):
// the current tunables with glibc.malloc.hugetlb=1 appended, or "" when nothing is to change (a
// glibc.malloc.hugetlb setting is there already: the re-executed process, or the user's own,
// e.g. hugetlb=0 to switch it off).
std::string huge_page_heap_tunables(const char* current);

// Whether this process can use a huge-page heap: glibc 2.35 or newer (older ones ignore the
// tunable) on a kernel whose transparent huge pages are "always" or "madvise" (not "never").
bool huge_page_heap_supported();

}  // namespace panoscan

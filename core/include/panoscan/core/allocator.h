// Process-wide settings of glibc's allocator for PanoScan's programs (the panoscan command and the
// benchmarks call it first thing in main).
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

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

// Asks the kernel to back [data, data + bytes) with transparent huge pages where it can (Linux,
// blocks of at least 8 MB; elsewhere a no-op). A fresh 4 KB page costs a page fault on its first
// touch, which on the 2-core VM was 7-9% of a panorama run at H = 1024 (hundreds of MB of
// measurement sets and solver vectors); a 2 MB page costs one fault for 512 of them. Only the
// whole 2 MB pages inside the block are advised. Returns whether the advice was given.
bool advise_huge_pages(void* data, std::size_t bytes);

// An allocator whose value-initialisation (vector::resize(n), vector(n)) default-initialises
// instead: a resized vector of doubles is not zero-filled. For the large buffers that a parallel
// loop writes in full right after sizing them (the panorama solver's 16 MB vectors at H = 1024):
// the zero fill was a serial pass over memory, and it touched the fresh pages on one thread, so
// their page faults were serial too; now the writing loop touches them on every core.
// Elements are still constructed as usual where a value is given (resize(n, value), assign, ...).
template <typename T, typename Base = std::allocator<T>>
class DefaultInitAllocator : public Base {
 public:
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U, typename std::allocator_traits<Base>::template rebind_alloc<U>>;
  };
  using Base::Base;
  DefaultInitAllocator() = default;
  template <typename U, typename B>
  DefaultInitAllocator(const DefaultInitAllocator<U, B>& other) noexcept : Base(static_cast<const B&>(other)) {}

  // Blocks of 8 MB and more get transparent huge pages (advise_huge_pages): they are the large
  // buffers this allocator is for, written right after they are sized.
  T* allocate(std::size_t n) {
    T* p = std::allocator_traits<Base>::allocate(static_cast<Base&>(*this), n);
    advise_huge_pages(p, n * sizeof(T));
    return p;
  }

  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    std::allocator_traits<Base>::construct(static_cast<Base&>(*this), p, std::forward<Args>(args)...);
  }
};

// A std::vector whose resize(n) leaves trivially constructible elements uninitialised (see above).
template <typename T>
using UninitialisedVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace panoscan

// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <vector>

// Transparent huge pages for large working buffers. A buffer's first touch costs a page fault per
// 4 KiB page; under a hypervisor each fault is a trap out of the guest, and a million-triangle
// mesh's encoder touches about 220 MB of fresh memory: 57,000 faults, a third of its time. Asked
// for 2 MiB pages before the first write, the kernel backs the buffer with a few hundred. Only a
// hint: without Linux (the WebAssembly decoder) or with THP off it does nothing.

namespace osteon::detail {

#if defined(__linux__) && !defined(__EMSCRIPTEN__)
/// Asks for huge pages under the 2 MiB-aligned part of [data, data + bytes), which must not be
/// written yet for the hint to pay.
void advise_huge_pages(void* data, size_t bytes);

/// Reserves room for n elements in an empty vector and advises huge pages under it, so that the
/// resize or push_backs that follow fault it in 2 MiB at a time.
template <class T>
void reserve_huge(std::vector<T>* v, size_t n) {
  v->reserve(n);
  if (v->empty()) advise_huge_pages(v->data(), n * sizeof(T));
}
#else
// Elsewhere (the WebAssembly decoder, whose download is budgeted) both compile to nothing.
inline void advise_huge_pages(void*, size_t) {}
template <class T>
void reserve_huge(std::vector<T>*, size_t) {}
#endif

}  // namespace osteon::detail

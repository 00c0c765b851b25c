// SPDX-License-Identifier: Apache-2.0
#include <cstddef>
#include <cstdint>
#include <cstring>

// The WebAssembly decoder's malloc: a bump allocator (linked with -sMALLOC=none in place of
// emmalloc). The decoder runs one decode at a time, and its wrapper (osteon_decoder.mjs) frees the
// input and the result once they are copied out, so every block's life ends with its decode: when
// no block is live, the whole heap is free again. Within a decode, blocks are stacked: the newest
// grows in place when reallocated (a vector growing by push_back), and freed blocks at the top go
// back at once. A freed block below a live one stays where it is, and a large request (64 KiB and
// up: the decoder's per-vertex and per-triangle arrays) first takes the newest run of adjacent
// freed blocks that holds it, so the geometry's arrays reuse what the connectivity's temporaries
// held. It is a fraction of emmalloc's code, and the download is budgeted (web/README.md "Size and
// speed" has the sizes and peak memory measured).
//
// Each block is 16-byte aligned (or more, for aligned_alloc), with a header in the 16 bytes before
// it: its size, the block below it, and whether it is freed. Memory grows by whole 64 KiB pages
// with memory.grow, up to the module's maximum; beyond it, malloc returns null (and operator new
// aborts, which the wrapper reports).

extern "C" unsigned char __heap_base;

namespace {

constexpr uintptr_t kAlign = 16;
constexpr uintptr_t kPage = 65536;
constexpr size_t kReuseBytes = 65536;  // requests this large look for freed blocks first

/// The 16 bytes before each block.
struct Header {
  size_t size;      // as asked for
  uintptr_t below;  // the block before it in memory, or 0
  size_t freed;     // 1 once freed while blocks above it were live
  size_t unused;
};
static_assert(sizeof(Header) == kAlign);

uintptr_t g_top = 0;   // the first free byte; 0 before the first block
uintptr_t g_last = 0;  // the newest block, or 0
size_t g_live = 0;     // blocks handed out and not yet freed

uintptr_t heap_start() {
  return (reinterpret_cast<uintptr_t>(&__heap_base) + kAlign - 1) & ~(kAlign - 1);
}

uintptr_t round_up(uintptr_t size) {
  return (size + kAlign - 1) & ~(kAlign - 1);
}

Header& header(uintptr_t block) {
  return *reinterpret_cast<Header*>(block - sizeof(Header));
}

/// Makes memory reach `end`; false when it cannot grow that far.
bool reach(uintptr_t end) {
  const uintptr_t have = __builtin_wasm_memory_size(0) * kPage;
  if (end <= have) return true;
  const uintptr_t pages = (end - have + kPage - 1) / kPage;
  return __builtin_wasm_memory_grow(0, pages) != static_cast<size_t>(-1);
}

void* bump(size_t size, uintptr_t align) {
  if (g_top == 0) g_top = heap_start();
  // Sizes near the address space's end would wrap; memory cannot reach 2^32 anyway.
  if (size > (uintptr_t{1} << 31) || align > (uintptr_t{1} << 16)) return nullptr;
  const uintptr_t start = (g_top + sizeof(Header) + align - 1) & ~(align - 1);
  const uintptr_t end = start + round_up(size);
  if (end < start || !reach(end)) return nullptr;
  header(start) = {size, g_last, 0, 0};
  g_top = end;
  g_last = start;
  ++g_live;
  return reinterpret_cast<void*>(start);
}

/// A block of `size` bytes in the newest run of freed blocks (between two live ones) that holds
/// it, or null. What the run has left over stays one freed block.
void* reuse(size_t size) {
  const uintptr_t need = round_up(size);
  uintptr_t above = 0;  // the live block above the run
  for (uintptr_t b = g_last; b != 0;) {
    if (!header(b).freed) {
      above = b;
      b = header(b).below;
      continue;
    }
    uintptr_t low = b;  // the run's lowest block
    while (header(low).below != 0 && header(header(low).below).freed) low = header(low).below;
    const uintptr_t end = above - sizeof(Header);  // freed blocks at the top were given back
    if (end - low >= need) {
      header(low) = {size, header(low).below, 0, 0};
      uintptr_t next = low;  // what `above` now sits on
      const uintptr_t rest = low + need + sizeof(Header);
      if (rest < end) {
        header(rest) = {end - rest, low, 1, 0};
        next = rest;
      }
      header(above).below = next;
      ++g_live;
      return reinterpret_cast<void*>(low);
    }
    b = header(low).below;
  }
  return nullptr;
}

}  // namespace

extern "C" {

void* malloc(size_t size) {
  if (size >= kReuseBytes) {
    if (void* block = reuse(size)) return block;
  }
  return bump(size, kAlign);
}

void free(void* pointer) {
  if (!pointer) return;
  if (--g_live == 0) {
    g_top = 0;
    g_last = 0;
    return;
  }
  header(reinterpret_cast<uintptr_t>(pointer)).freed = 1;
  // The newest blocks that are free go back to the heap at once.
  while (g_last != 0 && header(g_last).freed) {
    g_top = g_last - sizeof(Header);
    g_last = header(g_last).below;
  }
}

void* calloc(size_t count, size_t size) {
  if (size != 0 && count > SIZE_MAX / size) return nullptr;
  void* block = malloc(count * size);
  if (block) std::memset(block, 0, count * size);
  return block;
}

void* realloc(void* pointer, size_t size) {
  if (!pointer) return malloc(size);
  const uintptr_t block = reinterpret_cast<uintptr_t>(pointer);
  if (block == g_last) {  // the newest block grows or shrinks in place
    const uintptr_t end = block + round_up(size);
    if (size > (uintptr_t{1} << 31) || !reach(end)) return nullptr;
    g_top = end;
    header(block).size = size;
    return pointer;
  }
  void* moved = malloc(size);
  if (!moved) return nullptr;
  const size_t old = header(block).size;
  std::memcpy(moved, pointer, old < size ? old : size);
  free(pointer);
  return moved;
}

void* aligned_alloc(size_t align, size_t size) {
  return bump(size, align > kAlign ? align : kAlign);
}

int posix_memalign(void** out, size_t align, size_t size) {
  void* block = aligned_alloc(align, size);
  if (!block) return 12;  // ENOMEM
  *out = block;
  return 0;
}

}  // extern "C"

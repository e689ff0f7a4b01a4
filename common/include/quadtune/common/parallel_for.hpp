#pragma once
/// \file
/// ParallelFor: body(i) for every i in [begin, end) on a oneTBB arena of `threads` workers,
/// returning when every call has returned (an exception from a call is rethrown here).
///
/// oneTBB hands the calls to its workers through atomics inside libtbb. Debian's libtbb is not
/// built with ThreadSanitizer, so TSan cannot see that everything before ParallelFor happens
/// before each call, and each call before ParallelFor returns; under TSan (`__SANITIZE_THREAD__`
/// or clang's thread_sanitizer feature) ParallelFor states both edges with TSan's
/// acquire/release annotations. Elsewhere the annotations compile to nothing.
///
/// Thread safety: `body` is called concurrently from several threads.

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>

#if defined(__SANITIZE_THREAD__)
#define QUADTUNE_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define QUADTUNE_TSAN 1
#endif
#endif

#ifdef QUADTUNE_TSAN
extern "C" void __tsan_acquire(void* addr);  // NOLINT: ThreadSanitizer's interface
extern "C" void __tsan_release(void* addr);  // NOLINT
#endif

namespace quadtune {

/// Tells ThreadSanitizer that what this thread did so far happens before a later
/// HappensAfter(`token`) on another thread; nothing without TSan.
inline void HappensBefore([[maybe_unused]] void* token) {
#ifdef QUADTUNE_TSAN
  __tsan_release(token);
#endif
}

/// Tells ThreadSanitizer that every HappensBefore(`token`) so far happens before what this
/// thread does next; nothing without TSan.
inline void HappensAfter([[maybe_unused]] void* token) {
#ifdef QUADTUNE_TSAN
  __tsan_acquire(token);
#endif
}

namespace detail {
/// The addresses ParallelFor synchronises on. A worker must reach its token without reading
/// memory the caller wrote (the loop's closure is such memory), so the tokens are fixed
/// addresses shared by every loop: two loops running at once are then ordered for TSan too,
/// which can hide a race between them from TSan but never makes it report one.
inline char parallel_for_started = 0;
inline char parallel_for_finished = 0;

/// One index of a ParallelFor. Not inlined into oneTBB's loop, so that the compiler cannot read
/// `body` (the caller's memory) before the acquire that orders the read.
template <class Index, class Body>
struct AnnotatedCall {
  const Body* body;
  [[gnu::noinline]] void operator()(Index i) const {
    HappensAfter(&parallel_for_started);
    (*body)(i);
    HappensBefore(&parallel_for_finished);
  }
};
}  // namespace detail

template <class Index, class Body>
void ParallelFor(int threads, Index begin, Index end, const Body& body) {
  const detail::AnnotatedCall<Index, Body> call{&body};
  tbb::task_arena arena(std::max(1, threads));
  arena.execute([&] {
    HappensBefore(&detail::parallel_for_started);  // after every write the workers read
    tbb::parallel_for(begin, end, call);
  });
  HappensAfter(&detail::parallel_for_finished);
}

}  // namespace quadtune

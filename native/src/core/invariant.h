/* TSK_ASSERT(cond): a check of the library's own invariants (never of user input, which gets a
 * status and a message: an abort would take Blender and the artist's unsaved work with it).
 * Active in Debug builds and in the sanitizer and fuzzing builds, where a broken invariant
 * should stop at its cause; compiled out of Release builds (NDEBUG), the condition not even
 * evaluated, so it may be costly. */
#ifndef TSK_CORE_INVARIANT_H
#define TSK_CORE_INVARIANT_H

#if !defined(NDEBUG) || defined(TSK_ASSERTS)
#define TSK_ASSERTS_ON 1
/* Prints the condition and where it failed to stderr and aborts. */
_Noreturn void tsk_assert_fail(const char* cond, const char* file, int line, const char* func);
#define TSK_ASSERT(cond) ((cond) ? (void)0 : tsk_assert_fail(#cond, __FILE__, __LINE__, __func__))
#else
#define TSK_ASSERTS_ON 0
/* sizeof: the condition is type-checked and its variables count as used, but not evaluated */
#define TSK_ASSERT(cond) ((void)sizeof((cond) ? 1 : 0))
#endif

#endif

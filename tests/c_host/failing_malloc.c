/* Allocations that fail on request, for tests/test_c_model_no_memory.py: linked into the kernel
 * library with -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc, so that the library's own calls
 * (and only those: Python's are not wrapped) come here. failing_malloc_after(n): the first n
 * succeed, every later one fails; -1: none fails. failing_malloc_count(): how many were asked. */
#include <stddef.h>

void *__real_malloc(size_t size);
void *__real_calloc(size_t count, size_t size);
void *__real_realloc(void *p, size_t size);

static long allowed = -1, asked = 0;

__attribute__((visibility("default"))) void failing_malloc_after(long n)
{
    allowed = n;
    asked = 0;
}

__attribute__((visibility("default"))) long failing_malloc_count(void)
{
    return asked;
}

/* this allocation fails: the first `allowed` of them do not */
static int fails(void)
{
    ++asked;
    return allowed >= 0 && asked > allowed;
}

void *__wrap_malloc(size_t size)
{
    return fails() ? NULL : __real_malloc(size);
}

void *__wrap_calloc(size_t count, size_t size)
{
    return fails() ? NULL : __real_calloc(count, size);
}

void *__wrap_realloc(void *p, size_t size)
{
    return fails() ? NULL : __real_realloc(p, size);
}

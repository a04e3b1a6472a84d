/* cmocka includes in the order cmocka requires. */
#ifndef MSR_TEST_COMMON_H
#define MSR_TEST_COMMON_H
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#endif

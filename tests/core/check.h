// Checks for the host test programs of lib/core: count every check, print a failing one with
// its place (the first 30), carry on, and exit non-zero at the end when any failed.
#pragma once
#include <stdio.h>

static int g_checks = 0;
static int g_failures = 0;

#define CHECK_MSG(cond, ...)                                   \
  do {                                                         \
    ++g_checks;                                                \
    if (!(cond)) {                                             \
      ++g_failures;                                            \
      if (g_failures <= 30) {                                  \
        printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
        printf(__VA_ARGS__);                                   \
        printf("\n");                                          \
      }                                                        \
    }                                                          \
  } while (0)

#define CHECK(cond) CHECK_MSG(cond, "%s", "check failed")

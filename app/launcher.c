/* isoforge and isoforge-mpi: start the program itself (lib/isoforge/isoforge-main, or isoforge-mpi-main) with
 * malloc's heap in huge pages.
 *
 * glibc backs malloc's memory with transparent huge pages only when told so before the process starts, by
 * GLIBC_TUNABLES=glibc.malloc.hugetlb=1 (read by the dynamic loader, ahead of main). isoforge builds grids,
 * meshes and trees of many small blocks; on a virtual machine each 4 KB page fault costs microseconds, and
 * the tunable takes a third off some whole commands (docs/performance.md, "Huge pages for the whole
 * process"). This program adds the tunable, unless the user's GLIBC_TUNABLES already says something about
 * glibc.malloc.hugetlb (theirs wins: glibc.malloc.hugetlb=0 turns it off), and replaces itself with the
 * program: the same process, arguments, standard streams and exit status. It links nothing but the C
 * library and starts in about a millisecond.
 *
 * The program is looked for at ../lib/isoforge/ beside this file (the build tree's layout and the installed
 * one), then in the build tree and the install prefix compiled in. Under mpirun each rank's process is this
 * one until the exec, which keeps its pid, environment and MPI's variables: the rank is the program. */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

extern char** environ;

/* The launcher's name; its program is NAME-main: isoforge starts isoforge-main, isoforge-mpi starts
 * isoforge-mpi-main (CMake's isoforge_launcher() compiles this file for each). */
#ifndef LAUNCHER
#define LAUNCHER "isoforge"
#endif
#define PROGRAM LAUNCHER "-main"
#define TUNABLE "glibc.malloc.hugetlb=1"

/* dir/../lib/isoforge/PROGRAM for the directory of this executable, into out; 0 if it cannot be named. */
static int besideSelf(char* out, size_t size) {
    char self[PATH_MAX];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0) return 0;
    self[n] = '\0';
    char* slash = strrchr(self, '/');
    if (!slash) return 0;
    *slash = '\0';
    return snprintf(out, size, "%s/../lib/isoforge/" PROGRAM, self) < (int)size;
}

/* The environment with the tunable added to GLIBC_TUNABLES (or GLIBC_TUNABLES=TUNABLE added); NULL when
 * nothing needs adding or memory runs out (then the program runs without it). */
static char** withTunable(void) {
    size_t count = 0, at = (size_t)-1;
    for (; environ[count]; ++count)
        if (strncmp(environ[count], "GLIBC_TUNABLES=", 15) == 0) at = count;
    if (at != (size_t)-1 && strstr(environ[at], "glibc.malloc.hugetlb")) return NULL;
    char** env = calloc(count + 2, sizeof *env);
    if (!env) return NULL;
    memcpy(env, environ, count * sizeof *env);
    if (at == (size_t)-1) {
        env[count] = "GLIBC_TUNABLES=" TUNABLE;
        return env;
    }
    const size_t length = strlen(environ[at]) + 1 + strlen(TUNABLE) + 1;
    char* joined = malloc(length);
    if (!joined) {
        free(env);
        return NULL;
    }
    snprintf(joined, length, "%s%s" TUNABLE, environ[at], environ[at][15] ? ":" : "");
    env[at] = joined;
    return env;
}

int main(int argc, char** argv) {
    (void)argc;
    char** env = withTunable();
    char** use = env ? env : environ;
    char candidates[3][PATH_MAX];
    int n = 0;
    if (besideSelf(candidates[n], sizeof candidates[n])) ++n;
    snprintf(candidates[n++], PATH_MAX, "%s/" PROGRAM, ISOFORGE_BUILD_MODULE_DIR);
    snprintf(candidates[n++], PATH_MAX, "%s/" PROGRAM, ISOFORGE_INSTALL_MODULE_DIR);
    int error = ENOENT;
    for (int i = 0; i < n; ++i) {
        execve(candidates[i], argv, use);
        if (errno != ENOENT) error = errno; /* there but not runnable: the reason worth telling */
    }
    fprintf(stderr, LAUNCHER ": cannot start " LAUNCHER "'s program (%s); looked for:\n", strerror(error));
    for (int i = 0; i < n; ++i) fprintf(stderr, "  %s\n", candidates[i]);
    return 1;
}

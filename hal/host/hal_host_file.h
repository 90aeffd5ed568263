/* Files of the host programs, written whole or not at all, and inputs opened with a clear
 * reason when they cannot be read.
 *
 * Every output file of fleetsim (samples, validation sets, plans, tours, checkpoints through
 * the storage HAL, metrics, maps, summaries, profiles) goes through one writer:
 *   - hal_host_file_begin() refuses a target that exists but is not a regular file (a
 *     directory, a device such as /dev/full, a socket) and a path longer than PATH_MAX,
 *     creates the target's missing parent directories, then a temporary file
 *     `.NAME.PID.fstmp` beside the target (exclusively: it never opens an existing file);
 *   - every write is checked; hal_host_file_commit() flushes, fsyncs and closes it, then
 *     renames it over the target, so the target is either the previous file or the whole new
 *     one, never a part;
 *   - on any failure, and on hal_host_file_abort(), only the temporary file is removed. A
 *     path the program did not create is never unlinked or truncated.
 * Errors are negative errno codes of the real cause (-ENOSPC for a full disk, -EISDIR,
 * -ENAMETOOLONG, ...); hal_host_file_strerror() words them (-EEXIST: "exists and is not a
 * regular file"). Callers print "PATH: reason" and exit non-zero.
 *
 * Every temporary file a writer holds open is also noted in a fixed table of this process
 * (HAL_HOST_FILE_MAX_OPEN entries; a writer beyond them is simply not noted), so that a
 * program stopped by a signal can remove them at once (hal_host_file_remove_open_temporaries,
 * async-signal-safe; hal_host_stop.h). What is not removed then is cleared by the next run in
 * that folder (hal_host_file_clean_stale).
 *
 * Test seam: FLEETSIM_FAIL_WRITE_AFTER=N in the environment (read once per process) makes
 * the writers fail with ENOSPC once N bytes in total have been written through them, so
 * tests can exercise a full disk without a small file system.
 *
 * Not thread-safe per writer; distinct writers may be used from distinct threads. */
#ifndef HAL_HOST_FILE_H
#define HAL_HOST_FILE_H

#include <limits.h>
#include <stddef.h>
#include <stdio.h>

#define HAL_HOST_FILE_TMP_SUFFIX ".fstmp"
#define HAL_HOST_FILE_MAX_OPEN 32

typedef struct hal_host_file {
    FILE *f;
    int err;             /* first error seen (negative errno), 0 if none */
    int noted;           /* 1 + its entry in the table of open temporaries, 0: not noted */
    long long counted;   /* bytes charged to the test seam so far */
    char path[PATH_MAX]; /* the target */
    char tmp[PATH_MAX];  /* the temporary file beside it */
} hal_host_file_t;

/* Starts writing `path`. 0 or a negative errno (nothing was created then). */
FS_MUST_CHECK int hal_host_file_begin(hal_host_file_t *w, const char *path);

/* The stream to write to (fprintf, fwrite, libpng...). Errors are caught at commit. */
FILE *hal_host_file_stream(hal_host_file_t *w);

/* Writes len bytes. 0 or a negative errno (the writer then stays failed). */
FS_MUST_CHECK int hal_host_file_write(hal_host_file_t *w, const void *data, size_t len);

/* Makes the target the new file: flush, fsync, close, rename, fsync of the directory.
 * 0, or a negative errno and the target is untouched (the temporary file is removed). */
FS_MUST_CHECK int hal_host_file_commit(hal_host_file_t *w);

/* Gives up: closes and removes the temporary file; the target is untouched. Safe to call
 * after a failed begin or commit, and twice. */
void hal_host_file_abort(hal_host_file_t *w);

/* begin + write + commit. */
FS_MUST_CHECK int hal_host_file_write_all(const char *path, const void *data, size_t len);

/* Removes temporary files that writers in `dir` left behind when their process was killed
 * (`.*.fstmp` whose PID is not a live process).
 * Returns the number removed, or a negative errno when dir cannot be read. */
int hal_host_file_clean_stale(const char *dir);

/* Unlinks the temporary file of every writer of this process that is open now (their
 * commits then fail). Async-signal-safe (atomic loads, unlink): for a signal handler that is
 * about to _exit. Returns how many files it removed. */
int hal_host_file_remove_open_temporaries(void);

/* Opens an input file for reading: 0 and *out, or a negative errno: -ENOENT, -EACCES,
 * -EISDIR for a directory, ... */
FS_MUST_CHECK int hal_host_file_open_read(const char *path, FILE **out);

/* Makes `dir` and its missing parents (mkdir -p), refusing a component that exists and is
 * not a directory. 0 or a negative errno. */
FS_MUST_CHECK int hal_host_file_mkdirs(const char *dir);

/* strerror(-code), except -EEXIST: "exists and is not a regular file". */
const char *hal_host_file_strerror(int code);

#endif /* HAL_HOST_FILE_H */

/* hal_storage in a directory. A write goes through the host's one writer (hal_host_file.h):
 * a temporary file in the same directory, flushed with fsync, renamed over the blob (rename
 * is atomic on POSIX file systems), the directory fsynced so the rename itself survives a
 * power loss. Temporary names start with '.', which no valid blob name does, so they can
 * never collide with a blob; opening the storage removes the ones a killed run left. */
#include "hal_host.h"
#include "hal_host_file.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

struct hal_host_storage {
    char *dir;
};

/* Temporary files of earlier versions (".NAME.tmp", NAME a valid blob name) that a killed
 * run left: ours to remove. */
static void clean_legacy_tmp(const char *dir)
{
    DIR *d = opendir(dir);
    if (d == NULL)
        return;
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        size_t n = strlen(e->d_name);
        char blob[HAL_STORAGE_NAME_MAX];
        if (n < 6 || e->d_name[0] != '.' || strcmp(e->d_name + n - 4, ".tmp") != 0 ||
            n - 5 >= sizeof blob)
            continue;
        memcpy(blob, e->d_name + 1, n - 5);
        blob[n - 5] = '\0';
        char p[4096];
        if (hal_storage_name_valid(blob) && snprintf(p, sizeof p, "%s/%s", dir, e->d_name) < (int)sizeof p)
            unlink(p);
    }
    closedir(d);
}

int hal_host_storage_open(const char *dir, hal_host_storage_t **out)
{
    if (dir == NULL || dir[0] == '\0' || out == NULL || strlen(dir) > 3000u)
        return -EINVAL;
    *out = NULL;
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "hal_host_storage: cannot create '%s': %s\n", dir, strerror(errno));
        return -EIO;
    }
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "hal_host_storage: '%s' is not a directory\n", dir);
        return -EIO;
    }
    (void)hal_host_file_clean_stale(dir); /* best effort: a leftover is only a hidden file */
    clean_legacy_tmp(dir);
    hal_host_storage_t *s = calloc(1, sizeof(*s));
    if (s == NULL)
        return -ENOMEM;
    s->dir = strdup(dir);
    if (s->dir == NULL) {
        free(s);
        return -ENOMEM;
    }
    *out = s;
    return 0;
}

void hal_host_storage_close(hal_host_storage_t *s)
{
    if (s == NULL)
        return;
    free(s->dir);
    free(s);
}

static int errno_to_code(int e)
{
    switch (e) {
    case ENOENT: return -ENOENT;
    case ENOSPC:
    case EDQUOT: return -ENOSPC;
    default: return -EIO;
    }
}

/* Paths are built in caller stack buffers: no allocation per call. */
#define PATH_CAP 4096u

static int make_path(const hal_host_storage_t *s, const char *prefix, const char *name,
                     const char *suffix, char *path)
{
    int n = snprintf(path, PATH_CAP, "%s/%s%s%s", s->dir, prefix, name, suffix);
    return (n < 0 || (unsigned)n >= PATH_CAP) ? -EINVAL : 0;
}

int hal_host_storage_write(hal_host_storage_t *s, const char *name, const void *data, size_t len)
{
    if (s == NULL || !hal_storage_name_valid(name) || (data == NULL && len > 0))
        return -EINVAL;
    char path[PATH_CAP];
    if (make_path(s, "", name, "", path) != 0)
        return -EINVAL;
    int rc = hal_host_file_write_all(path, data, len);
    return rc == 0 ? 0 : errno_to_code(-rc);
}

int hal_host_storage_read(hal_host_storage_t *s, const char *name, void *buf, size_t cap,
                          size_t *len)
{
    if (s == NULL || !hal_storage_name_valid(name) || len == NULL || (buf == NULL && cap > 0))
        return -EINVAL;
    char path[PATH_CAP];
    if (make_path(s, "", name, "", path) != 0)
        return -EINVAL;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return errno_to_code(errno);
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return -EIO;
    }
    size_t size = (size_t)st.st_size;
    *len = size;
    if (size > cap) {
        close(fd);
        return -EMSGSIZE;
    }
    uint8_t *p = buf;
    size_t got = 0;
    while (got < size) {
        ssize_t r = read(fd, p + got, size - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            close(fd);
            return -EIO; /* the file shrank under us or the read failed */
        }
        got += (size_t)r;
    }
    close(fd);
    return 0;
}

int hal_host_storage_remove(hal_host_storage_t *s, const char *name)
{
    if (s == NULL || !hal_storage_name_valid(name))
        return -EINVAL;
    char path[PATH_CAP];
    if (make_path(s, "", name, "", path) != 0)
        return -EINVAL;
    if (unlink(path) != 0)
        return errno_to_code(errno);
    return 0;
}

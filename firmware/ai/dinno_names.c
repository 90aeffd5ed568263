/* The DiNNO enumerations' names (dinno.h): the spelling of the command lines and of
 * summary.txt, kept apart from the node update they configure. */
#include "ai/dinno.h"

#include <errno.h>
#include <string.h>

/* Names of the enumerations, in enum order (the CLI's spelling). */
static const char *const strategy_names[] = {"uniform", "separate", "kl"};
static const char *const kl_form_names[] = {"own", "reverse", "full"};
static const char *const kl_reduce_names[] = {"sum", "mean"};
static const char *const dual_rule_names[] = {"node", "link"};
#define N_OF(a) (sizeof(a) / sizeof((a)[0]))

static const char *name_of(const char *const *names, size_t n, int v)
{
    return v >= 0 && (size_t)v < n ? names[v] : "?";
}

/* The index of `name` in names, or -1. */
static int index_of(const char *const *names, size_t n, const char *name)
{
    for (size_t i = 0; name && i < n; i++)
        if (strcmp(name, names[i]) == 0)
            return (int)i;
    return -1;
}

const char *dinno_strategy_name(dinno_strategy_t s)
{
    return name_of(strategy_names, N_OF(strategy_names), (int)s);
}

int dinno_strategy_parse(const char *name, dinno_strategy_t *out)
{
    const int i = index_of(strategy_names, N_OF(strategy_names), name);
    if (i < 0 || !out)
        return -EINVAL;
    *out = (dinno_strategy_t)i;
    return 0;
}

const char *dinno_kl_form_name(dinno_kl_form_t f)
{
    return name_of(kl_form_names, N_OF(kl_form_names), (int)f);
}

int dinno_kl_form_parse(const char *name, dinno_kl_form_t *out)
{
    const int i = index_of(kl_form_names, N_OF(kl_form_names), name);
    if (i < 0 || !out)
        return -EINVAL;
    *out = (dinno_kl_form_t)i;
    return 0;
}

const char *dinno_kl_reduce_name(dinno_kl_reduce_t r)
{
    return name_of(kl_reduce_names, N_OF(kl_reduce_names), (int)r);
}

int dinno_kl_reduce_parse(const char *name, dinno_kl_reduce_t *out)
{
    const int i = index_of(kl_reduce_names, N_OF(kl_reduce_names), name);
    if (i < 0 || !out)
        return -EINVAL;
    *out = (dinno_kl_reduce_t)i;
    return 0;
}

const char *dinno_dual_rule_name(dinno_dual_rule_t r)
{
    return name_of(dual_rule_names, N_OF(dual_rule_names), (int)r);
}

int dinno_dual_rule_parse(const char *name, dinno_dual_rule_t *out)
{
    const int i = index_of(dual_rule_names, N_OF(dual_rule_names), name);
    if (i < 0 || !out)
        return -EINVAL;
    *out = (dinno_dual_rule_t)i;
    return 0;
}

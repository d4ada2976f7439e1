/* SPDX-License-Identifier: MIT */
/*
 * SIGINT and SIGTERM ask a long command to stop: the handler only records the
 * signal, the command polls it between frames, removes its temporaries on the
 * normal failure path and exits 128 + the signal, leaving earlier outputs as
 * they were. One copy for every command.
 */
#include <signal.h>

#include "tools/cmd.h"

volatile sig_atomic_t sp_cmd_stop_signal;

static void on_signal(int sig)
{
    sp_cmd_stop_signal = sig;
}

void sp_cmd_catch_signals(sp_cmd_signals *saved)
{
    struct sigaction sa = { .sa_handler = on_signal };
    sigemptyset(&sa.sa_mask);
    sp_cmd_stop_signal = 0;
    sigaction(SIGINT, &sa, &saved->old_int);
    sigaction(SIGTERM, &sa, &saved->old_term);
}

void sp_cmd_restore_signals(const sp_cmd_signals *saved)
{
    sigaction(SIGINT, &saved->old_int, NULL);
    sigaction(SIGTERM, &saved->old_term, NULL);
}

int sp_cmd_stopped_code(int code)
{
    return sp_cmd_stop_signal ? 128 + (int)sp_cmd_stop_signal : code;
}

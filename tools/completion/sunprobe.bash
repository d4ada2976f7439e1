# SPDX-License-Identifier: MIT
# bash completion for sunprobe. Commands and options are read from the program's own --help, so they
# never go stale: `sunprobe --help` lists the commands, `sunprobe CMD --help` (and `synth KIND --help`)
# the options. Installed to share/bash-completion/completions/sunprobe.

_sunprobe_words() { # help text on stdin -> the long options in it
    grep -oE -- '--[a-z][a-z0-9-]*' | sort -u
}

_sunprobe() {
    local cur=${COMP_WORDS[COMP_CWORD]} prev=${COMP_WORDS[COMP_CWORD-1]} prog=${COMP_WORDS[0]}
    COMPREPLY=()
    if [ "$COMP_CWORD" -eq 1 ]; then
        local cmds
        cmds=$("$prog" --help 2>/dev/null | sed -n '/^commands:/,/^$/p' | awk 'NR > 1 && NF { print $1 }')
        mapfile -t COMPREPLY < <(compgen -W "$cmds --help --version" -- "$cur")
        return
    fi
    local cmd=${COMP_WORDS[1]} sub=()
    if [ "$cmd" = synth ] && [ "$COMP_CWORD" -eq 2 ]; then
        mapfile -t COMPREPLY < <(compgen -W "selfie street turn" -- "$cur")
        return
    fi
    [ "$cmd" = synth ] && sub=("${COMP_WORDS[2]}")
    case "$prev" in # options taking a path: complete files
        -o|--output|--report|--truth|--imu|--meta|--frame-times|--dlib-model|--env|--background|--probe|--collection|--texture)
            mapfile -t COMPREPLY < <(compgen -f -- "$cur")
            return ;;
    esac
    if [[ "$cur" == -* ]]; then
        local opts
        opts=$("$prog" "$cmd" "${sub[@]}" --help 2>&1 | _sunprobe_words)
        mapfile -t COMPREPLY < <(compgen -W "$opts" -- "$cur")
    else
        mapfile -t COMPREPLY < <(compgen -f -- "$cur")
    fi
}
complete -o filenames -F _sunprobe sunprobe

#!/usr/bin/env bash
# The CPU the figures of `make bench` come from, as the first line of its output:
#   # cpu: AMD EPYC 9R14 (vendor AuthenticAMD, family 25, model 17 = Zen 4; avx512f avx512bw ...)
# Only the flags that change which kernels run (la_packed.c, q8_gemm.c) or how fast they go are
# listed. A figure is only comparable with figures of the same CPU: Zen 4 runs AVX-512 on two
# 256-bit FMA pipes, Zen 5 and Intel's AVX-512 cores on 512-bit ones, and a VM may hide flags.
set -euo pipefail
case "${1-}" in
    -h|--help) sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
esac
f=/proc/cpuinfo
[ -r "$f" ] || { echo "# cpu: unknown (no /proc/cpuinfo)"; exit 0; }
field() { sed -n "s/^$1[[:space:]]*: //p" "$f" | head -n1; }
name=$(field 'model name'); vendor=$(field 'vendor_id'); family=$(field 'cpu family')
model=$(field 'model'); flags=" $(field 'flags') $(field 'Features') "
# The microarchitecture, where family/model says it without doubt (AMD's families; Intel
# shares family 6 among many, so it is left to the model name there).
uarch=
if [ "$vendor" = AuthenticAMD ]; then
    case "$family" in
        23) uarch="Zen/Zen+/Zen 2" ;;
        25) if [ "$model" -ge 16 ] 2>/dev/null && [ "$model" -le 31 ] || { [ "$model" -ge 96 ] && [ "$model" -le 127 ]; } || { [ "$model" -ge 160 ] && [ "$model" -le 175 ]; }; then uarch="Zen 4"; else uarch="Zen 3"; fi ;;
        26) uarch="Zen 5" ;;
    esac
fi
want="avx2 fma avx512f avx512bw avx512vl avx512_vnni avx_vnni avx512_bf16 avx512_fp16 amx_tile asimd asimddp sve"
have=
for w in $want; do
    case "$flags" in *" $w "*) have+="${have:+ }$w" ;; esac
done
desc="vendor ${vendor:-?}, family ${family:-?}, model ${model:-?}${uarch:+ = $uarch}"
echo "# cpu: ${name:-$(uname -m)} ($desc; ${have:-no vector flags of interest}; $(nproc) cpus online)"

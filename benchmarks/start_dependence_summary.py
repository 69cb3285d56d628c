"""Summary of benchmarks/start_dependence_false_flags.py's records: the false-flag rate (Wilson 95 %
interval) and the largest moves of the losses, by kind of record."""
import json, math, sys
import numpy as np
rs = [json.loads(l) for l in open(sys.argv[1] if len(sys.argv) > 1 else "ff.jsonl")]
ok = [r for r in rs if "error" not in r]
err = [r for r in rs if "error" in r]
fl = [r for r in ok if r["flagged"]]
def wilson(k, n, z=1.96):
    p = k / n; d = 1 + z*z/n; c = (p + z*z/(2*n)) / d; h = z*math.sqrt(p*(1-p)/n + z*z/(4*n*n)) / d
    return max(0, c-h), min(1, c+h)
n = len(ok); k = len(fl)
print(f"records {len(rs)}, fitted {n}, errors {len(err)}, flagged {k}, rate {k/n:.4f}, Wilson95 {wilson(k,n)}")
from collections import Counter
print("verdicts", Counter(r["verdict"] for r in ok))
print("sim status", Counter(r["sim_status"] for r in ok), Counter(r["sim_solver"] for r in ok))
nocheck = [r for r in ok if r["check_text"] is None]
print("no check sentence (comparison not made):", len(nocheck))
for r in nocheck[:5]:
    print("  ", r["i"], r["periods"], [c for c in r["notes"] if "too short" in c or "later" in c][:2], [w[:150] for w in r["warnings"]][:3])
def summ(name, sel):
    z = np.array([r["move_sigmas"] for r in sel if not r["flagged"] and r["move_sigmas"] is not None and math.isfinite(r["move_sigmas"])])
    nan = sum(1 for r in sel if not r["flagged"] and not (r["move_sigmas"] is not None and math.isfinite(r["move_sigmas"])))
    if z.size:
        print(f"{name}: n={len(sel)} flagged={sum(r['flagged'] for r in sel)} unflagged z: n={z.size} median {np.median(z):.3g} p90 {np.percentile(z,90):.3g} p99 {np.percentile(z,99):.3g} max {z.max():.3g}  >3: {(z>3).sum()} >2: {(z>2).sum()}  nan {nan}")
summ("all", ok)
summ("pendulum", [r for r in ok if r["restoring"]=="pendulum"])
summ("spring", [r for r in ok if r["restoring"]=="spring"])
summ("drag", [r for r in ok if r["drag"]])
summ("ar1", [r for r in ok if r["ar1"]])
summ("white no drag", [r for r in ok if not r["ar1"] and not r["drag"]])
summ("all-viscous", [r for r in ok if not r["drag"] and r["weights"][1]==0])
summ("all-friction", [r for r in ok if not r["drag"] and r["weights"][0]==0])
summ("periods<15", [r for r in ok if r["periods"]<15])
print("verdicts not determined:", [(r["i"], r["verdict"], [w[:160] for w in r["warnings"]]) for r in ok if r["verdict"]!="determined"][:20])
top = sorted([r for r in ok if r["move_sigmas"] is not None and math.isfinite(r["move_sigmas"])], key=lambda r: -r["move_sigmas"])[:8]
for r in top:
    print("TOP", r["i"], r["restoring"], "drag" if r["drag"] else "", "ar1" if r["ar1"] else "", f"A={r['amp']:.3g} P={r['period']:.3g} N={r['periods']:.3g} spp={r['spp']:.3g} noise={r['noise_frac']:.3g} loss={r['loss_actual']:.2f} w={[round(x,2) for x in r['weights']]} z={r['move_sigmas']}", r["check_text"])
for r in fl:
    print("FLAG", json.dumps({k: r[k] for k in ("i","restoring","drag","ar1","amp","period","periods","spp","noise_frac","loss_actual","weights","rho","truth","verdict","move_sigmas")}), "\n   ", r["check_text"])
for r in err:
    print("ERR", r["i"], r["error"]); print(r["traceback"][-800:])
# relative move info when fits are at a bound

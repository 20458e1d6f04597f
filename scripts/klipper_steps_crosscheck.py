#!/usr/bin/python3
"""Cross-check `amctl steps` against the step commands Klipper's batch mode sends to its MCU.

    scripts/klipper_steps_crosscheck.py KLIPPER_DIR --amctl build/release/apps/amctl/amctl \
        --cfg tests/reference/klipper/steps_corexy.cfg FILE.gcode [FILE.gcode ...] [--out R.json]

KLIPPER_DIR is a Klipper checkout with a built Linux-process MCU dictionary (out/klipper.dict).
For each file this runs `klippy/klippy.py CFG -i FILE -o out.serial -d out/klipper.dict` and
`klippy/parsedump.py` (Klipper's own tools, run, not copied), expands every stepper's
`queue_step` commands into step clocks (a command's j-th step, j = 1..count, is
interval * j + add * j (j - 1) / 2 ticks after the previous command's last step;
`reset_step_clock` sets the base, `set_next_step_dir` the direction of the steps that follow;
clocks and intervals are 32-bit on the wire and are unwrapped, see decode_steps),
runs `amctl steps FILE --machine CFG --csv`, and compares per stepper: the step count, the
direction of each step, and each time. Klipper's time of a step is clock / CLOCK_FREQ (batch mode
maps print time to clock as int(print_time * CLOCK_FREQ)); its print time of amctl's t = 0 is
BUFFER_TIME_START (0.25 s, toolhead.py: the clock estimate of batch mode starts at 0 and the
first move waits that long); a fitted offset is reported beside it. With
dt = t_klipper - t_amctl - offset the check is |dt| <= 25 us + 1 tick (step compression moves a
step earlier by at most 25 us, MAX_STEPCOMPRESS_ERROR in stepper.py; the clock truncates).

Klipper drops a step that is followed by a step back within 750 us (`SDS_FILTER_TIME`,
stepcompress.c) so a motor does not buzz at a reversal; amctl emits both. The same filter is
applied to amctl's steps before the comparison (a pending step and an opposite one less than
750 us later are both removed) and the pairs removed are reported.

The JSON written (--out) holds counts and statistics only, no step lists.
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

SDS_FILTER_TIME_S = 0.000750
STEPCOMPRESS_TOLERANCE_S = 0.000025


def klipper_start_time(klipper_dir):
    with open(os.path.join(klipper_dir, 'klippy', 'toolhead.py')) as f:
        m = re.search(r'^BUFFER_TIME_START\s*=\s*([0-9.]+)', f.read(), re.M)
    if not m:
        sys.exit('no BUFFER_TIME_START in klippy/toolhead.py of ' + klipper_dir)
    return float(m.group(1))


def cfg_step_pins(cfg_path):
    """Stepper section name -> its step_pin (without '!' / '^'), from a printer.cfg."""
    pins, section = {}, None
    with open(cfg_path) as f:
        for line in f:
            line = line.split('#')[0].strip()
            m = re.match(r'^\[([^\]]+)\]$', line)
            if m:
                section = m.group(1).strip()
                continue
            m = re.match(r'^step_pin\s*[:=]\s*(\S+)', line)
            if m and section and (section.startswith('stepper') or section.startswith('extruder')):
                pins[section] = m.group(1).lstrip('!^~')
    return pins


STEP_COMMANDS = ('config_stepper', 'queue_step', 'set_next_step_dir', 'reset_step_clock')


def run_klipper_once(klipper_dir, cfg, gcode, workdir, python):
    klippy = os.path.join(klipper_dir, 'klippy')
    dict_path = os.path.join(klipper_dir, 'out', 'klipper.dict')
    serial = os.path.join(workdir, 'out.serial')
    log = os.path.join(workdir, 'klippy.log')
    cmd = [python, os.path.join(klippy, 'klippy.py')]
    args = [cfg, '-i', gcode, '-o', serial, '-d', dict_path, '-l', log]
    rc = subprocess.run(cmd + args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    with open(log) as f:
        text = f.read()
    if rc != 0:
        sys.exit('klippy failed on %s (exit %d); its log ends:\n%s' % (gcode, rc, text[-2000:]))
    if 'Exiting (print time' not in text or re.search(r'Must home|Unknown command|Error', text):
        sys.exit('klippy did not run %s cleanly, see %s' % (gcode, log))
    dump = subprocess.run([python, os.path.join(klippy, 'parsedump.py'), dict_path, serial],
                          check=True, capture_output=True, text=True).stdout
    return '\n'.join(l for l in dump.splitlines() if l.split(' ', 1)[0] in STEP_COMMANDS)


def run_klipper(klipper_dir, cfg, gcode, workdir, python, max_runs=6):
    """Klipper's step commands, from two batch runs that agree.

    Batch mode is not deterministic on a loaded machine: its output file is written by a
    background thread that klippy sometimes exits before (the dump then ends after the config
    commands), and where its buffer-runout stops fall depends on wall-clock timing. A run is
    accepted when a second run gives the same step commands and no run gave more."""
    with open(os.path.join(klipper_dir, 'out', 'klipper.dict')) as f:
        freq = float(json.load(f)['config']['CLOCK_FREQ'])
    seen = []
    for _ in range(max_runs):
        dump = run_klipper_once(klipper_dir, cfg, gcode, workdir, python)
        if dump in seen and len(dump) >= max(len(d) for d in seen):
            return dump, freq, len(seen) + 1
        seen.append(dump)
    sys.exit('%d batch runs of %s with %s gave %d different step streams'
             % (max_runs, gcode, cfg, len(set(seen))))


def decode_steps(dump):
    """oid -> (step_pin, clocks as int64 array, directions +1/-1 array)."""
    pin_of, state = {}, {}
    kv = re.compile(r'(\w+)=(\S+)')
    for line in dump.splitlines():
        name = line.split(' ', 1)[0]
        if name not in STEP_COMMANDS:
            continue
        a = dict(kv.findall(line))
        oid = int(a['oid'])
        if name == 'config_stepper':
            pin_of[oid] = a['step_pin']
            state[oid] = {'last': 0, 'dir': 1, 'clocks': [], 'dirs': []}
            continue
        s = state[oid]
        if name == 'set_next_step_dir':
            s['dir'] = 1 if int(a['dir']) else -1
        elif name == 'reset_step_clock':
            # A 32-bit clock on the wire (it wraps every 86 s at 50 MHz, and a stepper can be
            # idle for longer, e.g. Z through a layer): the 64-bit clock nearest to the latest
            # step of any stepper so far (commands go out in flush order, seconds ahead).
            c32, ref = int(a['clock']), max(t['last'] for t in state.values())
            s['last'] = ref + ((c32 - ref + (1 << 31)) % (1 << 32)) - (1 << 31)
        else:
            interval, count, add = int(a['interval']), int(a['count']), int(a['add'])
            if count == 1:
                # A step after a long idle (Z through a layer): stepcompress sends the 64-bit
                # gap modulo 2^32 (the MCU's timer is 32-bit and the command is timed to arrive
                # in the right window). Take the gap that puts the step nearest to the latest
                # step of any stepper so far (commands go out in flush order, seconds ahead).
                ref = max(t['last'] for t in state.values())
                k = max(0, round((ref - s['last'] - interval) / (1 << 32)))
                interval += k << 32
            j = np.arange(1, count + 1, dtype=np.int64)
            c = s['last'] + interval * j + add * j * (j - 1) // 2
            s['clocks'].append(c)
            s['dirs'].append(np.full(count, s['dir'], dtype=np.int8))
            s['last'] = int(c[-1])
    out = {}
    for oid, s in state.items():
        clocks = np.concatenate(s['clocks']) if s['clocks'] else np.zeros(0, np.int64)
        dirs = np.concatenate(s['dirs']) if s['dirs'] else np.zeros(0, np.int8)
        out[oid] = (pin_of[oid], clocks, dirs)
    return out


def run_amctl(amctl, cfg, gcode, workdir):
    path = os.path.join(workdir, 'amctl.csv')
    js = subprocess.run([amctl, 'steps', gcode, '--machine', cfg, '--csv', path, '--json'],
                        check=True, capture_output=True, text=True).stdout
    times, dirs = {}, {}
    with open(path) as f:
        r = csv.reader(f)
        if next(r) != ['stepper', 'time_s', 'direction']:
            sys.exit('unexpected amctl CSV header in ' + path)
        for name, t, d in r:
            times.setdefault(name, []).append(float(t))
            dirs.setdefault(name, []).append(int(d))
    os.remove(path)
    return ({n: np.array(v) for n, v in times.items()},
            {n: np.array(v, dtype=np.int8) for n, v in dirs.items()}, json.loads(js))


def sds_filter(times, dirs):
    """Klipper's rollback of a step followed by a step back within 750 us (see module doc)."""
    keep_t, keep_d, pairs = [], [], 0
    pending = None
    for t, d in zip(times.tolist(), dirs.tolist()):
        if pending is not None and d != pending[1] and t - pending[0] < SDS_FILTER_TIME_S:
            pending, pairs = None, pairs + 1
            continue
        if pending is not None:
            keep_t.append(pending[0])
            keep_d.append(pending[1])
        pending = (t, d)
    if pending is not None:
        keep_t.append(pending[0])
        keep_d.append(pending[1])
    return np.array(keep_t), np.array(keep_d, dtype=np.int8), pairs


def piecewise_shifts(amctl_times, diffs, offset, bound, window=200):
    """Where Klipper's times jump by a constant (a batch-mode stop, README): walking all steps
    in amctl's time order, a step off by more than the bound starts a new segment when the
    median of the next `window` steps is off too; its offset is the largest difference within
    30 us of that median. Returns [(amctl time, shift us)] (re-alignments within 0.1 s are one
    stop: its final shift) and the steps within the bound of their segment's offset."""
    t = np.concatenate([amctl_times[n][:len(diffs[n])] for n in diffs])
    d = np.concatenate([diffs[n] for n in diffs])
    order = np.argsort(t, kind='stable')
    t, d = t[order], d[order]
    off, shifts, within, i = offset, [], 0, 0
    while i < len(d):
        if abs(d[i] - off) > bound:
            nxt = d[i:i + window]
            med = float(np.median(nxt))
            if abs(med - off) > bound:
                near = nxt[np.abs(nxt - med) < 30e-6]
                off = float(near.max()) if len(near) else med
                shift = [round(float(t[i]), 6), round((off - offset) * 1e6, 3)]
                if shifts and t[i] - shifts[-1][0] < 0.1:  # still the same stop
                    shifts[-1][1] = shift[1]
                else:
                    shifts.append(shift)
        within += int(abs(d[i] - off) <= bound)
        i += 1
    return shifts, within


def compare(klipper_dir, amctl, cfg, gcode, python):
    with tempfile.TemporaryDirectory(prefix='stepx_') as wd:
        dump, freq, runs = run_klipper(klipper_dir, cfg, gcode, wd, python)
        ksteps = decode_steps(dump)
        at, ad, ajson = run_amctl(amctl, cfg, gcode, wd)
    pins = cfg_step_pins(cfg)
    by_name = {}
    for oid, (pin, clocks, dirs) in ksteps.items():
        names = [n for n, p in pins.items() if pin == p or pin.endswith('/' + p)]
        if len(names) != 1:
            sys.exit('cannot map MCU step pin %s to one stepper of %s' % (pin, cfg))
        by_name[names[0]] = (clocks / freq, dirs)
    tick = 1.0 / freq
    rows, diffs, filt = [], {}, {}
    for name in sorted(set(by_name) | set(at)):
        kt, kd = by_name.get(name, (np.zeros(0), np.zeros(0, np.int8)))
        raw_t = at.get(name, np.zeros(0))
        t, d, pairs = sds_filter(raw_t, ad.get(name, np.zeros(0, np.int8)))
        n = min(len(kt), len(t))
        rows.append({'stepper': name, 'klipper_steps': int(len(kt)),
                     'klipper_steps_positive': int(np.count_nonzero(kd > 0)),
                     'amctl_steps': int(len(raw_t)), 'amctl_sds_pairs_removed': pairs,
                     'amctl_steps_filtered': int(len(t)),
                     'count_equal': bool(len(kt) == len(t)),
                     'directions_equal': bool(len(kt) == len(t) and np.array_equal(kd, d))})
        diffs[name] = kt[:n] - t[:n]
        filt[name] = t
    # Klipper's print time of amctl's t = 0: batch mode's clock estimate starts at print time 0
    # and the first move waits BUFFER_TIME_START (toolhead.py). As a check, also fitted: the
    # largest difference within 30 us of that of amctl's first step (compression only moves
    # a step earlier; a batch-mode runout stop, README, shifts later steps by much more).
    offset = klipper_start_time(klipper_dir)
    firsts = [(filt[n][0], diffs[n][0]) for n in diffs if len(diffs[n])]
    d0 = min(firsts)[1] if firsts else offset
    alld = np.concatenate([v for v in diffs.values() if len(v)] + [np.array([d0])])
    fitted = float(alld[np.abs(alld - d0) < 30e-6].max())
    bound = STEPCOMPRESS_TOLERANCE_S + tick
    worst, within, total = 0.0, 0, 0
    for row in rows:
        dt = diffs[row['stepper']] - offset
        if len(dt):
            row.update({'max_abs_dt_us': round(float(np.abs(dt).max()) * 1e6, 3),
                        'mean_dt_us': round(float(dt.mean()) * 1e6, 3),
                        'rms_dt_us': round(float(np.sqrt((dt * dt).mean())) * 1e6, 3)})
            kt = diffs[row['stepper']] + filt[row['stepper']][:len(dt)] - offset
            row.update({'klipper_first_step_s': round(float(kt[0]), 9),
                        'klipper_last_step_s': round(float(kt[-1]), 9)})
            worst = max(worst, float(np.abs(dt).max()))
            within += int(np.count_nonzero(np.abs(dt) <= bound))
            total += len(dt)
    shifts, within_pw = piecewise_shifts(filt, diffs, offset, bound)
    return {'file': os.path.basename(gcode), 'cfg': os.path.basename(cfg),
            'clock_freq_hz': freq, 'klipper_print_time_of_amctl_t0_s': offset,
            'fitted_offset_s': round(fitted, 9), 'klipper_runs': runs,
            'amctl_print_time_s': ajson.get('print_time_s'),
            'max_abs_dt_us': round(worst * 1e6, 3), 'bound_us': round(bound * 1e6, 3),
            'steps_compared': total, 'steps_within_bound': within,
            'time_shifts': shifts, 'steps_within_bound_after_shifts': within_pw,
            'ok': bool(all(r['count_equal'] and r['directions_equal'] for r in rows)
                       and worst <= bound),
            'steppers': rows}


def head_copy(gcode, lines, outdir):
    out = os.path.join(outdir, os.path.basename(gcode))
    with open(gcode, errors='replace') as src, open(out, 'w') as dst:
        dst.write('SET_KINEMATIC_POSITION X=0 Y=0 Z=0\n')
        for i, line in enumerate(src):
            if i >= lines:
                break
            if re.match(r'^\s*G28\b', line, re.I):
                line = 'SET_KINEMATIC_POSITION X=0 Y=0 Z=0\n'
            dst.write(line)
        # Batch mode exits at the end of its input with the last moves still in the lookahead
        # unless something waits for them.
        dst.write('\nM400\n')
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('klipper_dir')
    p.add_argument('files', nargs='+')
    p.add_argument('--cfg', action='append', required=True,
                   help='printer.cfg (repeat for several); every file is run with every cfg')
    p.add_argument('--amctl', default='build/release/apps/amctl/amctl')
    p.add_argument('--python', default='/usr/bin/python3', help='python that runs klippy')
    p.add_argument('--head', type=int, metavar='N',
                   help='use only the first N lines of each file, after a '
                        'SET_KINEMATIC_POSITION X=0 Y=0 Z=0 that also replaces every G28 '
                        '(batch mode has no endstops), and an M400 after them')
    p.add_argument('--out', help='write the results as JSON here')
    a = p.parse_args()
    results = []
    headdir = tempfile.TemporaryDirectory(prefix='stepx_head_')
    files = [os.path.abspath(g) for g in a.files]
    if a.head:
        files = [head_copy(g, a.head, headdir.name) for g in files]
    for cfg in a.cfg:
        for g in files:
            r = compare(a.klipper_dir, a.amctl, os.path.abspath(cfg), g, a.python)
            if a.head:
                r['head_lines'] = a.head
            results.append(r)
            counts = ' '.join('%s=%d/%d%s' % (s['stepper'], s['klipper_steps'],
                                              s['amctl_steps_filtered'],
                                              '' if s['count_equal'] else '!')
                              for s in r['steppers'])
            print('%-5s %-16s %-42s max|dt| %8.3f us  %s' % (
                'ok' if r['ok'] else 'DIFF', r['cfg'], r['file'], r['max_abs_dt_us'], counts))
    if a.out:
        with open(a.out, 'w') as f:
            json.dump({'generated_by': 'scripts/klipper_steps_crosscheck.py', 'results': results},
                      f, indent=1)
            f.write('\n')
    return 0 if all(r['ok'] for r in results) else 1


if __name__ == '__main__':
    sys.exit(main())

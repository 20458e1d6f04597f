#!/usr/bin/python3
"""Cross-check amctl's printer.cfg reader against Klipper's own config reader.

For every Klipper config given, reads it with klippy/configfile.py (Klipper's code, loaded from
a Klipper checkout; nothing of it is copied here), derives the values Klipper would use for
[printer], [extruder] and [stepper_*] from Klipper's documented defaults, and compares them
with `amctl machine show FILE --json`. Files whose kinematics amctl does not support must be
rejected with a message saying so.

usage: klipper_cfg_crosscheck.py KLIPPER_CHECKOUT/klippy AMCTL_BINARY CFG...
prints one line per file and a summary; exit status 1 on any mismatch.
"""
import json
import math
import subprocess
import sys

sys.path.insert(0, sys.argv[1])
import configfile  # noqa: E402  (Klipper's reader)

amctl = sys.argv[2]
files = sys.argv[3:]
bad = 0
checked = 0
run_currents = 0
incomplete = 0
unsupported = 0
SUPPORTED = ('cartesian', 'corexy', 'corexz', 'hybrid_corexy', 'hybrid_corexz', 'delta', 'none',
             'winch', 'deltesian', 'generic_cartesian', 'polar', 'rotary_delta')


def close(a, b):
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


for fn in files:
    reader = configfile.ConfigFileReader()
    fc = reader.build_fileconfig_with_includes(reader.read_config_file(fn), fn)
    if not fc.has_section('printer'):
        continue
    kin = fc.get('printer', 'kinematics')
    res = subprocess.run([amctl, 'machine', 'show', fn, '--json'], capture_output=True, text=True)
    if kin not in SUPPORTED:
        ok = res.returncode != 0 and 'does not support' in res.stderr
        unsupported += 1
        if not ok:
            bad += 1
            print(f'MISMATCH {fn}: {kin} not rejected: {res.stderr.strip()}')
        continue
    if res.returncode != 0 and kin == 'generic_cartesian' and 'no carriage defined for axis' in res.stderr:
        # A sample fragment without a carriage for some axis (config/sample-corexyuv.cfg has no
        # Z): Klipper's generic_cartesian.py refuses it too ("No carriage defined for axis").
        axes = {fc.get(sec, 'axis') for sec in fc.sections() if sec.startswith('carriage ')
                and fc.has_option(sec, 'axis')}
        if axes != {'x', 'y', 'z'}:
            incomplete += 1
            continue
    if res.returncode != 0:
        bad += 1
        print(f'MISMATCH {fn}: amctl failed: {res.stderr.strip()}')
        continue
    got = json.loads(res.stdout)
    g = lambda sec, key, default: fc.getfloat(sec, key) if fc.has_option(sec, key) else default
    mv = g('printer', 'max_velocity', None)
    ma = g('printer', 'max_accel', None)
    exp = {
        ('printer', 'max_velocity'): mv,
        ('printer', 'max_accel'): ma,
        ('printer', 'square_corner_velocity'): g('printer', 'square_corner_velocity', 5.0),
        ('effective', 'max_z_velocity'): g('printer', 'max_z_velocity', mv),
        ('effective', 'max_z_accel'): g('printer', 'max_z_accel', ma),
    }
    if fc.has_option('printer', 'minimum_cruise_ratio'):
        exp[('printer', 'minimum_cruise_ratio')] = fc.getfloat('printer', 'minimum_cruise_ratio')
    elif fc.has_option('printer', 'max_accel_to_decel'):
        a2d = fc.getfloat('printer', 'max_accel_to_decel')
        exp[('printer', 'minimum_cruise_ratio')] = 1.0 - min(1.0, a2d / ma)
    else:
        exp[('printer', 'minimum_cruise_ratio')] = 0.5
    if fc.has_section('extruder'):
        nd = fc.getfloat('extruder', 'nozzle_diameter')
        fd = fc.getfloat('extruder', 'filament_diameter')
        area = math.pi * (fd * .5) ** 2
        ratio = 4. * nd ** 2 / area
        exp[('extruder', 'nozzle_diameter')] = nd
        exp[('effective', 'max_extrude_only_velocity')] = g('extruder', 'max_extrude_only_velocity', mv * ratio)
        exp[('effective', 'max_extrude_only_accel')] = g('extruder', 'max_extrude_only_accel', ma * ratio)
        exp[('effective', 'max_extrude_cross_section')] = g('extruder', 'max_extrude_cross_section', 4. * nd ** 2)
    for sec in fc.sections():
        towers = {'delta': ('a', 'b', 'c'), 'winch': ('a', 'b', 'c', 'd'),
                  'deltesian': ('left', 'right', 'y'), 'polar': ('bed', 'arm', 'z'),
                  'rotary_delta': ('a', 'b', 'c'), 'generic_cartesian': ()}.get(kin, ('x', 'y', 'z'))
        # stepper.py units_in_radians: the polar bed and the rotary delta's arms turn 2 pi per
        # turn of their final gear; generic_cartesian steppers are [stepper NAME].
        radians = (kin == 'polar' and sec == 'stepper_bed') or (kin == 'rotary_delta' and sec[8:] in towers)
        generic = kin == 'generic_cartesian' and sec.startswith('stepper ')
        if sec.startswith('stepper_') and sec[8:] in towers or sec == 'extruder' or generic:
            if not fc.has_option(sec, 'rotation_distance') and not radians:
                continue
            name = 'e' if sec == 'extruder' else sec.split()[-1] if generic else sec[8:]
            rd = 2 * math.pi if radians else fc.getfloat(sec, 'rotation_distance')
            full = fc.getint(sec, 'full_steps_per_rotation') if fc.has_option(sec, 'full_steps_per_rotation') else 200
            gear = 1.0
            if fc.has_option(sec, 'gear_ratio'):
                for pair in fc.get(sec, 'gear_ratio').split(','):
                    a, b = pair.split(':')
                    gear *= float(a) / float(b)
            steps_per_mm = full * fc.getint(sec, 'microsteps') * gear / rd
            exp[('steppers', name)] = steps_per_mm
            # A Trinamic driver section of this stepper: its run_current (tmc.py; RMS).
            for drv in ('tmc2130', 'tmc2208', 'tmc2209', 'tmc2240', 'tmc2660', 'tmc5160'):
                if fc.has_section(drv + ' ' + sec) and name in 'xyze':
                    exp[('run_current', name)] = fc.getfloat(drv + ' ' + sec, 'run_current')
    if kin == 'winch':
        for t in 'abcd':
            if fc.has_section('stepper_' + t):
                for axis in 'xyz':
                    exp[('winch', t + axis)] = fc.getfloat('stepper_' + t, 'anchor_' + axis)
    if kin == 'delta':
        # delta.py: delta_radius; rods and endstops of b and c default to a's.
        exp[('delta', 'radius')] = fc.getfloat('printer', 'delta_radius')
        arm_a = fc.getfloat('stepper_a', 'arm_length')
        es_a = fc.getfloat('stepper_a', 'position_endstop')
        exp[('delta', 'max_z')] = min(
            g('stepper_' + t, 'position_endstop', es_a) for t in 'abc')
        exp[('delta', 'arm_length_c')] = g('stepper_c', 'arm_length', arm_a)
    if kin == 'generic_cartesian':
        # generic_cartesian.py: each primary carriage's range; each stepper's carriages.
        for sec in fc.sections():
            if sec.startswith('carriage '):
                name = sec.split()[-1]
                exp[('carriages', name + '.position_max')] = fc.getfloat(sec, 'position_max')
            if sec.startswith('stepper '):
                exp[('carriages_of', sec.split()[-1])] = fc.get(sec, 'carriages')
    if kin == 'polar':
        exp[('printer', 'max_angular_velocity')] = g('printer', 'max_angular_velocity', None)
    if kin == 'rotary_delta':
        es_a = fc.getfloat('stepper_a', 'position_endstop')
        exp[('rotary_delta', 'shoulder_radius')] = fc.getfloat('printer', 'shoulder_radius')
        exp[('rotary_delta', 'shoulder_height')] = fc.getfloat('printer', 'shoulder_height')
        exp[('rotary_delta', 'max_z')] = min(g('stepper_' + t, 'position_endstop', es_a) for t in 'abc')
    mism = []
    for (sec, key), want in exp.items():
        if sec == 'carriages':
            name, field = key.split('.')
            have = got['carriages'][name][field]
        elif sec == 'carriages_of':
            have = got['steppers'][key]['carriages']
            if have != want:
                mism.append(f'{sec}.{key}: amctl {have} klipper {want}')
            continue
        elif want is None:
            if key in got.get(sec, {}):
                mism.append(f'{sec}.{key}: amctl {got[sec][key]} klipper unset')
            continue
        elif sec == 'winch':
            have = got['steppers'][key[0]]['anchor_' + key[1]]
        elif sec == 'run_current':
            run_currents += 1
            have = got['steppers'][key].get('run_current')
            if have is None:
                mism.append(f'{sec}.{key}: amctl unset klipper {want}')
                continue
        elif (sec, key) == ('delta', 'arm_length_c'):
            have = got['steppers']['c'].get('arm_length', got['steppers']['a']['arm_length'])
        else:
            have = got[sec][key]['steps_per_mm'] if sec == 'steppers' else got[sec][key]
        if not close(have, want):
            mism.append(f'{sec}.{key}: amctl {have} klipper {want}')
    checked += 1
    if mism:
        bad += 1
        print(f'MISMATCH {fn}: ' + '; '.join(mism))
print(f'{checked} configs of supported kinematics compared ({run_currents} Trinamic run_current '
      f'values among them), {unsupported} other kinematics rejected, '
      f'{incomplete} incomplete generic_cartesian samples refused as Klipper refuses them, {bad} mismatches')
sys.exit(1 if bad else 0)

#!/usr/bin/env python3
"""Tables of meshstream_codec_levers_v3's JSON (one file per model and qp) for
/work/notes/levers-v3.md. Usage: levers_v3_report.py FILE.json ..."""
import json, sys

runs = []
for f in sys.argv[1:]:
    for j in json.load(open(f)):
        runs.append(j)
name = lambda j: '%s %d' % (j['model'].split('.')[0].replace('stanford-', ''), j['qp'])
hdr = '| | ' + ' | '.join(name(j) for j in runs) + ' |\n|---|' + '---:|' * len(runs)

def row(label, fn, fmt='%.3f'):
    vals = []
    for j in runs:
        try:
            v = fn(j)
            vals.append(fmt % v if isinstance(v, (int, float)) else str(v))
        except (KeyError, TypeError, ValueError):
            vals.append('-')
    print('| %s | %s |' % (label, ' | '.join(vals)))

def ad(j, kind, key):
    return j['item1_' + kind]['adaptive_per_datagram'][key]['total']

def best(j, kind, prefix):
    return min(v['total'] for k, v in j['item1_' + kind]['adaptive_per_datagram'].items() if k.startswith(prefix))

print('### Item 1: static tables against adaptive models per datagram (bits per split)\n')
for kind, label in (('geometry', 'geometry datagrams (positions + channels)'), ('structure', 'structure datagrams (rank)')):
    print('\n**%s**\n' % label)
    print(hdr)
    rs = lambda j: j['real_stream']
    if kind == 'geometry':
        row('today, real payload bytes (incl. coder flush)', lambda j: rs(j)['payload_geometry'])
    else:
        row('today, real payload bytes (incl. coder flush)', lambda j: rs(j)['payload_structure'])
    g = lambda j: j['item1_' + kind]
    row('**today exact** (the writer\'s models with reuse, ideal coder; tables incl. flags%s)' % (', alpha' if kind == 'geometry' else ''), lambda j: g(j)['today_exact']['total'])
    row('today exact: of which tables', lambda j: g(j)['today_exact']['tables'])
    row('order-0 per refinement, no table (bound)', lambda j: g(j)['order0_per_refinement']['total'])
    row('(a) static, fresh table every refinement, incl. table bytes', lambda j: g(j)['static_fresh_tables']['total'])
    row('(a) of which table bytes', lambda j: g(j)['static_fresh_tables']['tables'])
    row('(a2) static, 1-byte parametric model per slot and refinement', lambda j: g(j)['static_parametric_1byte']['total'])
    row('(b) adaptive, uniform start (inc 32, halve at 2^16)', lambda j: ad(j, kind, 'b_uniform_inc32_lim16'))
    row('(b) best of inc 16/32, limit 2^13/2^16', lambda j: best(j, kind, 'b_uniform'))
    row('(c) adaptive from the refinement\'s table (inc 32, 2^16, prior 4096)', lambda j: ad(j, kind, 'c_refinement_table_inc32_lim16_prior4096'))
    row('(c) best of sweep', lambda j: best(j, kind, 'c_refinement'))
    row('(d) adaptive from one table per stream (inc 32, 2^16, prior 4096)', lambda j: ad(j, kind, 'd_stream_table_inc32_lim16_prior4096'))
    row('(d) best of sweep', lambda j: best(j, kind, 'd_stream'))
    row('(e) adaptive from the previous refinement\'s table (inc 32, 2^16, prior 4096)', lambda j: ad(j, kind, 'e_previous_refinement_table_inc32_lim16_prior4096'))
    row('(f) adaptive from a 1-byte parametric model per slot and refinement (inc 32, 2^16, prior 4096)', lambda j: ad(j, kind, 'f_parametric_1byte_inc32_lim16_prior4096'))
    row('(f) best of sweep', lambda j: best(j, kind, 'f_parametric'))
    row('(g) per slot and refinement the better start of (f) and (c)', lambda j: ad(j, kind, 'g_best_of_parametric_or_table_per_slot_inc32_lim16_prior4096'))
    row('(h) per slot and refinement the best of static table (a), (f) and (c)', lambda j: ad(j, kind, 'h_best_of_static_table_or_adaptive_parametric_or_table_per_slot'))
    row('reference: one adaptive model set per refinement (not decodable alone)', lambda j: g(j)['adaptive_per_datagram']['ref_uniform_whole_refinement_not_decodable_alone']['total'])
print()
print('\n**both kinds + every model table and alpha**\n')
print(hdr)
row('today, real: payloads + control-block models, flags, alpha', lambda j: j['real_stream']['payload_geometry'] + j['real_stream']['payload_structure'] + j['real_stream']['control_models_flags_alpha'])
row('**today exact** (simulated writer, ideal coder)', lambda j: j['item1_geometry']['today_exact']['total'] + j['item1_structure']['today_exact']['total'])
row('(a) simulated static fresh tables (no flush, no reuse)', lambda j: j['item1_geometry']['static_fresh_tables']['total'] + j['item1_structure']['static_fresh_tables']['total'])
row('(f) parametric + adaptive (geometry), (d) stream table (structure)', lambda j: ad(j, 'geometry', 'f_parametric_1byte_inc32_lim16_prior4096') + ad(j, 'structure', 'd_stream_table_inc32_lim16_prior4096'))
row('(h) geometry + (d) structure', lambda j: ad(j, 'geometry', 'h_best_of_static_table_or_adaptive_parametric_or_table_per_slot') + ad(j, 'structure', 'd_stream_table_inc32_lim16_prior4096'))
row('saved by (h)+(d) against today exact', lambda j: j['item1_geometry']['today_exact']['total'] + j['item1_structure']['today_exact']['total'] - ad(j, 'geometry', 'h_best_of_static_table_or_adaptive_parametric_or_table_per_slot') - ad(j, 'structure', 'd_stream_table_inc32_lim16_prior4096'))
row('saved by (f)+(d) against today exact', lambda j: j['item1_geometry']['today_exact']['total'] + j['item1_structure']['today_exact']['total'] - ad(j, 'geometry', 'f_parametric_1byte_inc32_lim16_prior4096') - ad(j, 'structure', 'd_stream_table_inc32_lim16_prior4096'))
row('datagrams (structure + geometry)', lambda j: '%d + %d' % (j['real_stream']['datagrams_structure'], j['real_stream']['datagrams_geometry']), '%s')

def ctx_table(item, variants, baseline='none'):
    print(hdr)
    for v, label in variants:
        for m, mlabel in (('order0', 'order-0, no tables (ceiling)'), ('static_fresh_tables', 'static, fresh tables'),
                          ('static_parametric_1byte', 'static, 1-byte parametric'),
                          ('adaptive_parametric_prior4096', 'adaptive per datagram from 1-byte parametric'),
                          ('adaptive_stream_table_prior4096', 'adaptive per datagram from stream table')):
            row('%s: %s' % (label, mlabel), lambda j, v=v, m=m: j[item][v][m]['total'])

print('\n### Item 2: geometry contexts (bits per split, geometry datagrams)\n')
ctx_table('item2_geometry_contexts', [('none', 'no context (baseline)'), ('same_split_mag4', 'c1 by |c0|, c2 by |c0|+|c1| (4 classes)'),
                                      ('same_split_mag8', 'same, 8 classes'), ('valence4_UNSAFE', 'valence class (UNSAFE)'),
                                      ('scale3_UNSAFE', 'ring scale 3 classes (UNSAFE)'), ('scale5_UNSAFE', 'ring scale 5 classes (UNSAFE)'),
                                      ('aniso5_UNSAFE', 'ring anisotropy 5 classes (UNSAFE)'),
                                      ('mag6_x_scale3_UNSAFE', 'magnitude 6 x scale 3 (UNSAFE)')])
print('\n### Item 5: structure contexts (bits per split, structure datagrams)\n')
ctx_table('item5_structure_contexts', [('none', 'no context (baseline)'), ('valence4_UNSAFE', 'valence class (UNSAFE)'),
                                       ('keygap5_UNSAFE', 'key gap best/second 5 classes (UNSAFE)'),
                                       ('valence4_x_keygap5_UNSAFE', 'valence x key gap (UNSAFE)'),
                                       ('k_given_a_bucket', 'K symbol by A symbol')])
print('\n### Item 4: split bits (bits per split, reliable)\n')
print(hdr)
row('today, real block bytes (incl. length varint, flush)', lambda j: j['real_stream']['split_bit_blocks'])
row('inferable bits (share of coded bits)', lambda j: j['item4_inferable_fraction'])
s4 = lambda j, k, m: j['item4_split_bits'][k][m]
for k in ['today_2age_related', 'today_plus_inference', 'since5_related', 'today_x_since4', 'today_x_reldeg4', 'today_x_nsplits4',
          'today_x_gp', 'today_x_baseval3', 'today_x_childprev', 'inf_since5_rel_reldeg4', 'inf_since4_rel_gp_reldeg3',
          'inf_since5_rel_reldeg4_nsplits3', 'inf_young_since5_rel_gp_reldeg4_nsplits3']:
    n = runs[0]['item4_split_bits'][k]['contexts']
    row('%s (%d ctx): shift-5 bit models reset per refinement' % (k, n), lambda j, k=k: s4(j, k, 'adaptive_shift5_reset_per_refinement'))
    row('%s: shift-5, one set per stream' % k, lambda j, k=k: s4(j, k, 'adaptive_shift5_whole_stream'))
    row('%s: counts (halved at 1024), one set per stream' % k, lambda j, k=k: s4(j, k, 'counts_whole_stream'))
print('\n### Item 3: geometry predictors (bits per split, positions only, order-0 per refinement and component)\n')
print(hdr)
p3 = lambda j: j['item3_predictors']
row('v2 exact (library CodeSplitVector, the stream\'s alpha)', lambda j: p3(j)['v2_exact_laplacian_alpha'])
row('v2 Laplacian through the estimate path (prediction rounded in the frame)', lambda j: p3(j)['v2_estimate_path_laplacian_alpha'])
row('two alphas (tangential, normal), + 1 byte per refinement', lambda j: p3(j)['two_alphas_t_n'] + p3(j)['two_alphas_t_n_param_bits'])
for k, label in [('ls_lap_one_weight', 'LS: Laplacian, one weight'), ('ls_lap_t_n', 'LS: Laplacian, t/n weights'),
                 ('ls_lap_wing_t_n', 'LS: + wing difference'), ('ls_lap_sides_t_n', 'LS: + side centroid difference'),
                 ('ls_lap_umbrella_t_n', 'LS: + w\'s umbrella (m - ring centroid)'), ('ls_lap_ring2_t_n', 'LS: + 2-ring term (sides\' mean Laplacian difference)'),
                 ('ls_lap_sides_strict_ring2_t_n', 'LS: lap, sides, strict sides, 2-ring; t/n'), ('ls_all6_t_n', 'LS: all six, t/n'),
                 ('ls_all6_one_set', 'LS: all six, one weight set')]:
    row(label + ' (incl. 12-bit weights per refinement)', lambda j, k=k: p3(j)[k]['total'])
print('\n**Items 1 + 3 together: geometry datagrams (positions + channels, tables, alpha or weights), estimate path**\n')
print(hdr)
cb = lambda j, a, b: j['item13_combined_geometry'][a][b]
row('v2 Laplacian, today\'s writer', lambda j: cb(j, 'laplacian_estimate_path', 'today_writer'))
row('v2 Laplacian, (f) parametric + adaptive per datagram', lambda j: cb(j, 'laplacian_estimate_path', 'adaptive_parametric'))
row('LS Laplacian + 2-ring (t/n), today\'s writer', lambda j: cb(j, 'ls_lap_ring2_t_n', 'today_writer'))
row('LS Laplacian + 2-ring (t/n), (f) parametric + adaptive per datagram', lambda j: cb(j, 'ls_lap_ring2_t_n', 'adaptive_parametric'))
row('saved by both', lambda j: cb(j, 'laplacian_estimate_path', 'today_writer') - cb(j, 'ls_lap_ring2_t_n', 'adaptive_parametric'))
print('\n### Item 6: per-refinement overhead today (bits per split)\n')
print(hdr)
rs = lambda j: j['real_stream']
row('refinements', lambda j: rs(j)['refinements'], '%d')
row('control block: model flags, tables, alpha', lambda j: rs(j)['control_models_flags_alpha'])
row('datagram headers', lambda j: rs(j)['datagram_headers'])
row('END datagrams (about 8 bytes each, sent, not stored)', lambda j: rs(j)['end_datagrams_bytes_est'])
row('range coder flush (real payloads - exact simulated symbols)', lambda j: rs(j)['coder_flush'])
row('total overhead (models + headers + flush, END excluded)', lambda j: rs(j)['control_models_flags_alpha'] + rs(j)['datagram_headers'] + rs(j)['coder_flush'])
row('bytes per datagram header', lambda j: rs(j)['datagram_headers'] * j['splits'] / 8 / (rs(j)['datagrams_structure'] + rs(j)['datagrams_geometry']), '%.1f')
row('model bytes per refinement', lambda j: rs(j)['control_models_flags_alpha'] * j['splits'] / 8 / rs(j)['refinements'], '%.1f')

// shellsim_icu.sv — the ICU's intersection pipeline in synthesizable SystemVerilog.
//
// One stage register per stage of the Rust model (hw/src/units/icu.rs, stages in
// hw/src/datapath/stages.rs; the divider's stages in hw/src/datapath/divider.rs):
//   r0 translate → r1 shear (rounding point A) → r2 edges → r3 interpolate
//   → rd[0..DIV_STAGES-1] divide (DIV_BITS quotient bits each, rounding point B)
//   → rr result.
// Widths come from package shellsim_cfg, written by `shellsim rtl --hw FILE --out DIR` from the
// same configuration the model reads (hw/src/config/datapath.rs, `Formats`).
//
// Handshake as the model's ICU: the whole pipeline stalls while the result register holds a
// result that cannot leave (out_valid && !out_ready); otherwise every register advances and
// a job enters when in_valid (in_ready = !stall). Arrays are flattened into packed vectors
// (vertex i, axis a at index 3*i + a) so that Verilator and Yosys read the same text.

// Widths are module parameters whose defaults come from the package (Yosys 0.23 reads neither
// an import in a module header nor packed arrays of arrays: arrays are flattened, functions
// are Verilog-2001 style).
module shellsim_icu #(
    parameter int F          = shellsim_cfg::F,
    parameter int CW         = shellsim_cfg::CW,
    parameter int SW         = shellsim_cfg::SW,
    parameter int TW         = shellsim_cfg::TW,
    parameter int RW         = shellsim_cfg::RW,
    parameter int EW         = shellsim_cfg::EW,
    parameter int DW         = shellsim_cfg::DW,
    parameter int NW         = shellsim_cfg::NW,
    parameter int TTW        = shellsim_cfg::TTW,
    parameter int DIV_BITS   = shellsim_cfg::DIV_BITS,
    parameter int DIV_STAGES = shellsim_cfg::DIV_STAGES,
    parameter int QF         = shellsim_cfg::QF,
    parameter int SHIFT_N    = shellsim_cfg::SHIFT_N,
    parameter int SHIFT_D    = shellsim_cfg::SHIFT_D,
    parameter int XW         = shellsim_cfg::XW,
    parameter int YW         = shellsim_cfg::YW,
    parameter int CMPW       = shellsim_cfg::CMPW
) (
    input  logic               clk,
    input  logic               rst,
    // The job: a ray record's set-up and a patch record (triangles: is_quad = 0, v3 unused).
    input  logic               in_valid,
    output logic               in_ready,
    input  logic [31:0]        in_tag,
    input  logic [3*CW-1:0]    in_o,       // origin x, y, z (coordinate format)
    input  logic [1:0]         in_kx,
    input  logic [1:0]         in_ky,
    input  logic [1:0]         in_kz,
    input  logic [SW-1:0]      in_sx,      // shear factors (shear format)
    input  logic [SW-1:0]      in_sy,
    input  logic [SW-1:0]      in_sz,
    input  logic               in_quad,
    input  logic [12*CW-1:0]   in_v,       // 4 vertices × (x, y, z)
    // The result: hit and t (t format), with the divider's exception flags.
    output logic               out_valid,
    input  logic               out_ready,
    output logic [31:0]        out_tag,
    output logic               out_hit,
    output logic [TTW-1:0]     out_t,
    output logic               out_near_zero,
    output logic               out_saturated
);

  logic              rr_valid, rr_hit, rr_nz, rr_sat;   // the result register (below)
  logic [31:0]       rr_tag;
  logic [TTW-1:0]    rr_t;

  logic adv;
  assign adv      = !(rr_valid && !out_ready);
  assign in_ready = adv;

  // ---------------------------------------------------------------------------------------
  // Stage 1, translate (Rust: stages.rs `translate`): p_i = v_i − o, exact. Triangles leave
  // p3 at zero, as the model computes only n_verts vertices.
  logic              r0_valid, r0_quad;
  logic [31:0]       r0_tag;
  logic [12*TW-1:0]  r0_p;
  logic [1:0]        r0_kx, r0_ky, r0_kz;
  logic [SW-1:0]     r0_sx, r0_sy, r0_sz;

  logic [12*TW-1:0]  c0_p;
  always_comb begin : c_translate
    for (int i = 0; i < 4; i++)
      for (int a = 0; a < 3; a++) begin
        if (i < 3 || in_quad)
          c0_p[(3*i+a)*TW +: TW] = TW'($signed(in_v[(3*i+a)*CW +: CW]))
                                 - TW'($signed(in_o[a*CW +: CW]));
        else
          c0_p[(3*i+a)*TW +: TW] = '0;
      end
  end

  always_ff @(posedge clk) begin
    if (rst) r0_valid <= 1'b0;
    else if (adv) begin
      r0_valid <= in_valid;
      r0_tag   <= in_tag;
      r0_quad  <= in_quad;
      r0_p     <= c0_p;
      r0_kx    <= in_kx;
      r0_ky    <= in_ky;
      r0_kz    <= in_kz;
      r0_sx    <= in_sx;
      r0_sy    <= in_sy;
      r0_sz    <= in_sz;
    end
  end

  // ---------------------------------------------------------------------------------------
  // Stage 2, shear into ray space (Rust: `shear`). Rounding point A: the products
  // s·p_kz (2F fractional bits) are rounded to F bits, half up: (x + 2^(F−1)) >>> F.
  logic              r1_valid, r1_quad;
  logic [31:0]       r1_tag;
  logic [4*RW-1:0]   r1_x, r1_y, r1_z;

  function automatic signed [TW-1:0] axis;
    input [12*TW-1:0] p;
    input integer i;
    input [1:0] k;
    axis = p[(3*i+k)*TW +: TW];
  endfunction

  function automatic signed [RW-1:0] round_a;
    input signed [SW+TW-1:0] prod;
    logic signed [SW+TW:0] s;
    begin
      s = $signed({prod[SW+TW-1], prod}) + (SW+TW+1)'(1 << (F-1));
      round_a = RW'(s >>> F);
    end
  endfunction

  logic [4*RW-1:0] c1_x, c1_y, c1_z;
  always_comb begin : c_shear
    for (int i = 0; i < 4; i++) begin : per_vertex
      logic signed [TW-1:0] px, py, pz;
      px = axis(r0_p, i, r0_kx);
      py = axis(r0_p, i, r0_ky);
      pz = axis(r0_p, i, r0_kz);
      if (i < 3 || r0_quad) begin
        c1_x[i*RW +: RW] = RW'(px) - round_a($signed(r0_sx) * pz);
        c1_y[i*RW +: RW] = RW'(py) - round_a($signed(r0_sy) * pz);
        c1_z[i*RW +: RW] = round_a($signed(r0_sz) * pz);
      end else begin
        c1_x[i*RW +: RW] = '0;
        c1_y[i*RW +: RW] = '0;
        c1_z[i*RW +: RW] = '0;
      end
    end
  end

  always_ff @(posedge clk) begin
    if (rst) r1_valid <= 1'b0;
    else if (adv) begin
      r1_valid <= r0_valid;
      r1_tag   <= r0_tag;
      r1_quad  <= r0_quad;
      r1_x     <= c1_x;
      r1_y     <= c1_y;
      r1_z     <= c1_z;
    end
  end

  // ---------------------------------------------------------------------------------------
  // Stage 3, edge functions and the inside test (Rust: `edges`). e_k = x_k·y_(k+1) −
  // y_k·x_(k+1), exact; a quad is the triangles (v0, v2, v3) and (v0, v1, v2) on its
  // diagonal; a triangle is inside when its three edge functions share a sign, an exact zero
  // kept only on a top-left edge (an edge that projects to a point bounds nothing).
  logic              r2_valid, r2_quad, r2_inside;
  logic [31:0]       r2_tag;
  logic [4*RW-1:0]   r2_z;
  logic [4*EW-1:0]   r2_e;
  logic [EW-1:0]     r2_diag;
  logic              r2_orient_neg;   // orient = −1 (clockwise in ray space) when set

  function automatic signed [RW-1:0] rx;
    input [4*RW-1:0] v;
    input integer i;
    rx = v[i*RW +: RW];
  endfunction

  function automatic signed [EW-1:0] edge_fn;
    input [4*RW-1:0] x, y;
    input integer a, b;
    edge_fn = EW'(rx(x, a) * rx(y, b)) - EW'(rx(y, a) * rx(x, b));
  endfunction

  // An edge's part of the test: false when its function is an exact zero and the edge
  // (a → b, negated for a clockwise triangle) is not top-left; top_left(dx, dy) =
  // dy > 0 || (dy == 0 && dx < 0). An edge that projects to a point bounds nothing.
  function automatic edge_ok;
    input [4*RW-1:0] x, y;
    input signed [EW-1:0] e;
    input integer a, b;
    input neg;
    logic signed [RW:0] dx, dy;
    begin
      dx = rx(x, b) - rx(x, a);
      dy = rx(y, b) - rx(y, a);
      if (neg) begin
        dx = -dx;
        dy = -dy;
      end
      edge_ok = !(e == 0 && (dx != 0 || dy != 0) && !(dy > 0 || (dy == 0 && dx < 0)));
    end
  endfunction

  // One triangle's test over edges (e_k, a_k → b_k): {inside, clockwise}.
  function automatic [1:0] tri_test;
    input [4*RW-1:0] x, y;
    input signed [EW-1:0] e0;
    input integer a0, b0;
    input signed [EW-1:0] e1;
    input integer a1, b1;
    input signed [EW-1:0] e2;
    input integer a2, b2;
    logic pos, neg;
    begin
      pos = (e0 > 0) || (e1 > 0) || (e2 > 0);
      neg = (e0 < 0) || (e1 < 0) || (e2 < 0);
      tri_test = {(pos != neg) && edge_ok(x, y, e0, a0, b0, neg)
                  && edge_ok(x, y, e1, a1, b1, neg) && edge_ok(x, y, e2, a2, b2, neg), neg};
    end
  endfunction

  logic [4*EW-1:0] c2_e;
  logic [EW-1:0]   c2_diag;
  logic            c2_inside, c2_neg;
  always_comb begin : c_edges
    logic [1:0] ta, tb;
    logic signed [EW-1:0] e0, e1, e2, e3, dg;
    ta = '0;
    tb = '0;
    c2_inside = 1'b0;
    c2_neg = 1'b0;
    e0 = edge_fn(r1_x, r1_y, 0, 1);
    e1 = edge_fn(r1_x, r1_y, 1, 2);
    e2 = r1_quad ? edge_fn(r1_x, r1_y, 2, 3) : edge_fn(r1_x, r1_y, 2, 0);
    e3 = r1_quad ? edge_fn(r1_x, r1_y, 3, 0) : '0;
    dg = r1_quad ? edge_fn(r1_x, r1_y, 0, 2) : '0;
    c2_e    = {e3, e2, e1, e0};
    c2_diag = dg;
    if (r1_quad) begin
      ta = tri_test(r1_x, r1_y, dg, 0, 2, e2, 2, 3, e3, 3, 0);
      tb = tri_test(r1_x, r1_y, e0, 0, 1, e1, 1, 2, -dg, 2, 0);
      c2_inside = ta[1] || tb[1];
      c2_neg    = ta[1] ? ta[0] : (tb[1] ? tb[0] : 1'b0);
    end else begin
      ta = tri_test(r1_x, r1_y, e0, 0, 1, e1, 1, 2, e2, 2, 0);
      c2_inside = ta[1];
      c2_neg    = ta[1] ? ta[0] : 1'b0;
    end
  end

  always_ff @(posedge clk) begin
    if (rst) r2_valid <= 1'b0;
    else if (adv) begin
      r2_valid      <= r1_valid;
      r2_tag        <= r1_tag;
      r2_quad       <= r1_quad;
      r2_z          <= r1_z;
      r2_e          <= c2_e;
      r2_diag       <= c2_diag;
      r2_inside     <= c2_inside;
      r2_orient_neg <= c2_neg;
    end
  end

  // ---------------------------------------------------------------------------------------
  // Stage 4, interpolate (Rust: `interpolate`): the weights of the triangle holding the ray
  // against the vertices' z, exact: t = num/den with den > 0. Not inside: all zero.
  logic              r3_valid, r3_ok;
  logic [31:0]       r3_tag;
  logic [NW-1:0]     r3_num;
  logic [DW-1:0]     r3_den;

  function automatic signed [EW-1:0] ex;
    input [4*EW-1:0] e;
    input integer k;
    ex = e[k*EW +: EW];
  endfunction

  logic [NW-1:0] c3_num;
  logic [DW-1:0] c3_den;
  logic          c3_ok;
  always_comb begin : c_interpolate
    logic signed [EW:0] w0, w1, w2;   // one bit more: −diag
    logic signed [RW-1:0] z0, z1, z2;
    logic signed [DW-1:0] den;
    logic signed [NW-1:0] num;
    logic d_nonneg;
    d_nonneg = r2_orient_neg ? ($signed(r2_diag) <= 0) : ($signed(r2_diag) >= 0);
    if (!r2_quad) begin
      w0 = ex(r2_e, 1); w1 = ex(r2_e, 2); w2 = ex(r2_e, 0);
      z0 = rx(r2_z, 0); z1 = rx(r2_z, 1); z2 = rx(r2_z, 2);
    end else if (d_nonneg) begin
      w0 = ex(r2_e, 2); w1 = ex(r2_e, 3); w2 = $signed(r2_diag);
      z0 = rx(r2_z, 0); z1 = rx(r2_z, 2); z2 = rx(r2_z, 3);
    end else begin
      w0 = ex(r2_e, 1); w1 = -$signed({r2_diag[EW-1], r2_diag}); w2 = ex(r2_e, 0);
      z0 = rx(r2_z, 0); z1 = rx(r2_z, 1); z2 = rx(r2_z, 2);
    end
    den = DW'(w0) + DW'(w1) + DW'(w2);
    num = NW'(w0 * z0) + NW'(w1 * z1) + NW'(w2 * z2);
    if (den < 0) begin
      den = -den;
      num = -num;
    end
    if (r2_inside) begin
      c3_ok  = den != 0;
      c3_num = num;
      c3_den = den;
    end else begin
      c3_ok  = 1'b0;
      c3_num = '0;
      c3_den = '0;
    end
  end

  always_ff @(posedge clk) begin
    if (rst) r3_valid <= 1'b0;
    else if (adv) begin
      r3_valid <= r2_valid;
      r3_tag   <= r2_tag;
      r3_ok    <= c3_ok;
      r3_num   <= c3_num;
      r3_den   <= c3_den;
    end
  end

  // ---------------------------------------------------------------------------------------
  // Stages 5.., divide (Rust: divider.rs `DividerStage`, equal to stages.rs `divide`).
  // Rounding point B, to nearest (ties away from zero) as a restoring division:
  //   X = 2N + D', Y = 2D' (N = num·2^(FT−F) or num; D' = den or den·2^(F−FT));
  //   Q = ⌊X / Y⌋ over QF = DIV_STAGES·DIV_BITS quotient bits, DIV_BITS per stage.
  // A job that cannot hit (not ok, or num < 0) divides X = 0 by Y = 1. ovf: Q ≥ 2^QF.
  // Stage k's fields at [k*W +: W] (flattened arrays).
  logic [DIV_STAGES-1:0]     rd_valid, rd_cand, rd_nz, rd_ovf;  // cand: ok and num ≥ 0
  logic [DIV_STAGES*32-1:0]  rd_tag;
  logic [DIV_STAGES*XW-1:0]  rd_r;   // the partial remainder
  logic [DIV_STAGES*QF-1:0]  rd_q;   // quotient bits so far (those still to come zero)
  logic [DIV_STAGES*YW-1:0]  rd_y;

  // DIV_BITS restoring steps on quotient bits QF−1−j·DIV_BITS down.
  function automatic [XW+QF-1:0] div_steps;
    input [XW-1:0] r_in;
    input [QF-1:0] q_in;
    input [YW-1:0] y;
    input integer j;
    logic [CMPW-1:0] r, ys;
    logic [QF-1:0] q;
    begin
      r = CMPW'(r_in);
      q = q_in;
      for (int s = 0; s < DIV_BITS; s++) begin
        ys = CMPW'(y) << (QF - 1 - j * DIV_BITS - s);
        if (r >= ys) begin
          r = r - ys;
          q[QF-1-j*DIV_BITS-s] = 1'b1;
        end
      end
      div_steps = {XW'(r), q};
    end
  endfunction

  logic            c4_cand, c4_nz, c4_ovf;
  logic [XW-1:0]   c4_x;
  logic [YW-1:0]   c4_y;
  always_comb begin : c_divide_in
    c4_cand = r3_ok && !r3_num[NW-1];
    c4_nz   = c4_cand && (r3_den < DW'(1 << F));
    if (c4_cand) begin
      c4_x = (XW'(r3_num) << (SHIFT_N + 1)) + (XW'(r3_den) << SHIFT_D);
      c4_y = YW'(r3_den) << (SHIFT_D + 1);
    end else begin
      c4_x = '0;
      c4_y = YW'(1);
    end
    c4_ovf = CMPW'(c4_x) >= (CMPW'(c4_y) << QF);
  end

  logic [DIV_STAGES*(XW+QF)-1:0] stepped;
  always_comb begin : c_divide
    stepped[0 +: XW+QF] = div_steps(c4_x, '0, c4_y, 0);
    for (int k = 1; k < DIV_STAGES; k++)
      stepped[k*(XW+QF) +: XW+QF] = div_steps(rd_r[(k-1)*XW +: XW], rd_q[(k-1)*QF +: QF],
                                              rd_y[(k-1)*YW +: YW], k);
  end

  always_ff @(posedge clk) begin
    if (rst) rd_valid <= '0;
    else if (adv) begin
      rd_valid[0]      <= r3_valid;
      rd_tag[0 +: 32]  <= r3_tag;
      rd_cand[0]       <= c4_cand;
      rd_nz[0]         <= c4_nz;
      rd_ovf[0]        <= c4_ovf;
      rd_y[0 +: YW]    <= c4_y;
      for (int k = 1; k < DIV_STAGES; k++) begin
        rd_valid[k]        <= rd_valid[k-1];
        rd_tag[k*32 +: 32] <= rd_tag[(k-1)*32 +: 32];
        rd_cand[k]         <= rd_cand[k-1];
        rd_nz[k]           <= rd_nz[k-1];
        rd_ovf[k]          <= rd_ovf[k-1];
        rd_y[k*YW +: YW]   <= rd_y[(k-1)*YW +: YW];
      end
      for (int k = 0; k < DIV_STAGES; k++) begin
        rd_r[k*XW +: XW] <= stepped[k*(XW+QF)+QF +: XW];
        rd_q[k*QF +: QF] <= stepped[k*(XW+QF) +: QF];
      end
    end
  end

  // ---------------------------------------------------------------------------------------
  // The result stage (Rust: the ICU's last register, `Reg::t`): a hit when the job could
  // hit and t fits its format (t ≤ 2^(TTW−1) − 1); otherwise saturated (counted, no hit).
  logic c5_fits;
  logic [QF-1:0] q_last;
  assign q_last  = rd_q[(DIV_STAGES-1)*QF +: QF];
  assign c5_fits = !rd_ovf[DIV_STAGES-1] && (q_last <= QF'((64'(1) << (TTW - 1)) - 1));

  always_ff @(posedge clk) begin
    if (rst) rr_valid <= 1'b0;
    else if (adv) begin
      rr_valid <= rd_valid[DIV_STAGES-1];
      rr_tag   <= rd_tag[(DIV_STAGES-1)*32 +: 32];
      rr_hit   <= rd_cand[DIV_STAGES-1] && c5_fits;
      rr_t     <= (rd_cand[DIV_STAGES-1] && c5_fits) ? TTW'(q_last) : '0;
      rr_nz    <= rd_nz[DIV_STAGES-1];
      rr_sat   <= rd_cand[DIV_STAGES-1] && !c5_fits;
    end
  end

  assign out_valid     = rr_valid;
  assign out_tag       = rr_tag;
  assign out_hit       = rr_hit;
  assign out_t         = rr_t;
  assign out_near_zero = rr_nz;
  assign out_saturated = rr_sat;

endmodule

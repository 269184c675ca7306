// shellsim_dda.sv — the CTU's exact fixed-point 3D-DDA step in synthesizable SystemVerilog.
//
// Rust counterpart: hw/src/datapath/dda.rs (`FixedDda::step`, `exit_beyond`, `entry_beyond`,
// `entry_at_or_beyond`). Per axis: N_a, the distance (coordinate LSBs) to the next cell
// boundary, and D_a = |d_a|; the next axis is the least N_a/D_a by exact cross-multiplication
// (ties: lowest axis; D_a = 0 never wins). A step adds the cell size to N_a. Leaving the grid
// through a face pins that axis and pushes its N_a on by OVERSHOOT; a pinned axis winning
// again ends the walk. No division, no rounding.
//
// One registered step per accepted state, with the ICU's handshake (the register holds while
// out_valid && !out_ready). The comparisons against t use the state *before* the step (as the
// CTU asks them of the cell it is in); the register holds the state after it.

// Widths are module parameters whose defaults come from the package (see shellsim_icu.sv).
module shellsim_dda #(
    parameter int FT        = shellsim_cfg::FT,
    parameter int TTW       = shellsim_cfg::TTW,
    parameter int CB        = shellsim_cfg::CB,
    parameter int NBW       = shellsim_cfg::NBW,
    parameter int DENW      = shellsim_cfg::DENW,
    parameter int PW        = shellsim_cfg::PW,
    parameter int OVERSHOOT = shellsim_cfg::OVERSHOOT
) (
    input  logic                clk,
    input  logic                rst,
    input  logic                in_valid,
    output logic                in_ready,
    input  logic [31:0]         in_tag,
    input  logic [3*CB-1:0]     in_c,          // the current cell
    input  logic [3*CB-1:0]     in_dims,       // cells per axis
    input  logic [5:0]          in_step,       // per axis: 2-bit −1, 0, +1
    input  logic [3*NBW-1:0]    in_n,          // N_a (signed)
    input  logic [3*DENW-1:0]   in_den,        // D_a = |d_a|
    input  logic [NBW-1:0]      in_cell,       // the cell edge (coordinate LSBs)
    input  logic [NBW-1:0]      in_entry_num,  // the current cell's entry t = num/den
    input  logic [DENW-1:0]     in_entry_den,
    input  logic [2:0]          in_pinned,
    input  logic [TTW-1:0]      in_t,          // a t (t format) to compare the cell with
    output logic                out_valid,
    input  logic                out_ready,
    output logic [31:0]         out_tag,
    output logic                out_moved,     // false: the ray has left the grid
    output logic [3*CB-1:0]     out_c,
    output logic [3*NBW-1:0]    out_n,
    output logic [NBW-1:0]      out_entry_num,
    output logic [DENW-1:0]     out_entry_den,
    output logic [2:0]          out_pinned,
    output logic                out_exit_beyond,       // next crossing beyond t
    output logic                out_entry_beyond,      // entry > t
    output logic                out_entry_at_or_beyond // entry ≥ t
);

  logic adv;
  assign adv      = !(out_valid && !out_ready);
  assign in_ready = adv;

  function automatic signed [NBW-1:0] nx;
    input [3*NBW-1:0] n;
    input integer a;
    nx = n[a*NBW +: NBW];
  endfunction

  function automatic [DENW-1:0] dx;
    input [3*DENW-1:0] d;
    input integer a;
    dx = d[a*DENW +: DENW];
  endfunction

  // The axis with the least N_a/D_a (3: none, every D_a zero). Ties keep the lower axis.
  function automatic [1:0] next_axis;
    input [3*NBW-1:0] n;
    input [3*DENW-1:0] d;
    logic [1:0] best;
    logic signed [PW-1:0] lhs, rhs;
    begin
      best = 2'd3;
      for (int a = 0; a < 3; a++) begin
        if (dx(d, a) != 0) begin
          if (best == 2'd3) best = 2'(a);
          else begin
            lhs = PW'(nx(n, a)) * $signed({1'b0, dx(d, {30'b0, best})});
            rhs = PW'(nx(n, {30'b0, best})) * $signed({1'b0, dx(d, a)});
            if (lhs < rhs) best = 2'(a);
          end
        end
      end
      next_axis = best;
    end
  endfunction

  logic             c_moved;
  logic [3*CB-1:0]  c_c;
  logic [3*NBW-1:0] c_n;
  logic [NBW-1:0]   c_en;
  logic [DENW-1:0]  c_ed;
  logic [2:0]       c_pin;
  logic             c_xb, c_eb, c_eab;

  always_comb begin : c_step
    logic done;
    logic [1:0] a;
    logic signed [CB+1:0] nc;
    logic signed [PW-1:0] lhs, rhs;
    nc    = '0;
    lhs   = '0;
    rhs   = '0;
    c_xb  = 1'b1;
    c_c   = in_c;
    c_n   = in_n;
    c_en  = in_entry_num;
    c_ed  = in_entry_den;
    c_pin = in_pinned;
    c_moved = 1'b0;
    done  = 1'b0;
    // At most one pass per axis pinned, then a move or the end: four passes.
    for (int pass = 0; pass < 4; pass++) begin
      if (!done) begin
        a = next_axis(c_n, in_den);
        if (a == 2'd3 || c_pin[{30'b0, a}]) done = 1'b1;
        else begin
          nc = (CB+2)'(c_c[a*CB +: CB]) + (CB+2)'($signed(in_step[a*2 +: 2]));
          if (nc < 0 || nc >= $signed((CB+2)'(in_dims[a*CB +: CB]))) begin
            c_pin[{30'b0, a}] = 1'b1;
            c_n[a*NBW +: NBW] = nx(c_n, a) + NBW'(OVERSHOOT);
          end else begin
            c_c[a*CB +: CB] = CB'(nc);
            c_en = c_n[a*NBW +: NBW];
            c_ed = dx(in_den, a);
            c_n[a*NBW +: NBW] = nx(c_n, a) + $signed(in_cell);
            c_moved = 1'b1;
            done = 1'b1;
          end
        end
      end
    end
    // The comparisons with t, on the state before the step.
    a = next_axis(in_n, in_den);
    if (a == 2'd3) c_xb = 1'b1;
    else begin
      lhs = PW'(nx(in_n, a)) <<< FT;
      rhs = PW'($signed(in_t)) * $signed({1'b0, dx(in_den, a)});
      c_xb = lhs > rhs;
    end
    lhs = PW'($signed(in_entry_num)) <<< FT;
    rhs = PW'($signed(in_t)) * $signed({1'b0, in_entry_den});
    c_eb  = lhs > rhs;
    c_eab = lhs >= rhs;
  end

  always_ff @(posedge clk) begin
    if (rst) out_valid <= 1'b0;
    else if (adv) begin
      out_valid              <= in_valid;
      out_tag                <= in_tag;
      out_moved              <= c_moved;
      out_c                  <= c_c;
      out_n                  <= c_n;
      out_entry_num          <= c_en;
      out_entry_den          <= c_ed;
      out_pinned             <= c_pin;
      out_exit_beyond        <= c_xb;
      out_entry_beyond       <= c_eb;
      out_entry_at_or_beyond <= c_eab;
    end
  end

endmodule

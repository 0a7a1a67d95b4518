(* Entry point of the protocol port: run as  mathics -q -f Main.wl  from this directory
   (wolfram/run-port does that). *)
Get["DynVal.wl"];
Get["Protocol.wl"];
Quiet[DynValProtocol`serve[]];

//! FICTIONAL fixture schemas for the transaction tests. Nothing here comes
//! from a vendor document.

pub const MC: &str = r#"
[schema]
id = "fictional-txn-mc"
title = "FICTIONAL: MC6000-like drive for transaction tests"
protocol = "lustbus-mc"
code_style = "lust"
spec = "fictional"
fictional = true

[schema.identify]
codes = [91]

[[code]]
number = 4
name = "PROG"
role = "command"
title = "PROG"
spec = "fictional"
type = "PT_USIGN8"
kind = "ram-control"
width = 1

[[code]]
number = 80
name = "SLOAD"
role = "command"
title = "SLOAD"
spec = "fictional"
type = "PT_INTEGER16"
kind = "ram-control"
width = 2
access = "standstill"

[[code]]
number = 81
name = "SBAUD"
role = "baud-rate"
title = "SBAUD"
spec = "fictional"
type = "PT_USIGN16"
kind = "eeprom"
width = 2

[[code]]
number = 82
name = "SADDR"
role = "bus-address"
title = "SADDR"
spec = "fictional"
type = "PT_USIGN8"
kind = "eeprom"
width = 1

[[code]]
number = 85
name = "SERR"
role = "status"
title = "SERR"
spec = "fictional"
type = "PT_BINARY8"
read_clears = true
width = 1

[[code]]
number = 91
name = "TYPE"
title = "TYPE"
spec = "fictional"
type = "PT_USIGN16"
access = "ro"

[[code]]
number = 100
name = "KPA"
title = "Card value A"
spec = "fictional"
type = "PT_INT32Q16"
unit = "1/min"
kind = "eeprom"
width = 4
card_writeable = true
default = "0"

[[code]]
number = 101
name = "KPB"
title = "Card value B"
spec = "fictional"
type = "PT_USIGN16"
kind = "eeprom"
width = 2
card_writeable = true
default = 10

[[code]]
number = 102
name = "SWTCH"
title = "Card switch"
spec = "fictional"
type = "PT_USIGN8"
kind = "eeprom"
width = 1
card_writeable = true
[code.values]
0 = "Off"
1 = "On"

[[code]]
number = 110
name = "NCA"
title = "Non-card EEPROM A"
spec = "fictional"
type = "PT_INT32Q16"
kind = "eeprom"
width = 4

[[code]]
number = 111
name = "NCB"
title = "Non-card EEPROM B"
spec = "fictional"
type = "PT_USIGN16"
kind = "eeprom"
width = 2

[[code]]
number = 112
name = "NCC"
title = "Non-card EEPROM C"
spec = "fictional"
type = "PT_INT32Q16"
kind = "eeprom"
width = 4

[[code]]
number = 120
name = "RSIO"
title = "RAM control value"
spec = "fictional"
type = "PT_INTEGER16"
kind = "ram-control"
width = 2

[[code]]
number = 130
name = "PASS"
title = "Password"
spec = "fictional"
type = "PT_PASSWORD"
kind = "eeprom"
width = 2

[[code]]
number = 140
name = "ACT"
title = "Actual value"
spec = "fictional"
type = "PT_INTEGER16"
kind = "ram-actual"
access = "ro"
"#;

pub const TMD: &str = r#"
[schema]
id = "fictional-txn-tmd"
title = "FICTIONAL: Tmd-like drive for transaction tests"
protocol = "lecom"
code_style = "lenze"
spec = "fictional"
default_type = "VD"
fictional = true

[[code]]
number = 1
name = "control_source"
role = "control-source"
title = "Setpoint and control source"
spec = "fictional"
min = "0"
max = "3"
default = "0"

[[code]]
number = 2
name = "load_lenze_setting"
role = "command"
title = "Load Lenze setting"
spec = "fictional"
default = "0"

[[code]]
number = 11
name = "max_output_frequency"
title = "Maximum output frequency"
spec = "fictional"
unit = "Hz"
default = "50"

[[code]]
number = 12
name = "acceleration_time"
title = "Acceleration time"
spec = "fictional"
unit = "s"
default = "5"

[[code]]
number = 13
name = "deceleration_time"
title = "Deceleration time"
spec = "fictional"
unit = "s"
default = "5"

[[code]]
number = 14
name = "operating_mode"
role = "operating-mode"
title = "Operating mode"
spec = "fictional"
default = "2"

[[code]]
number = 39
name = "fixed_setpoint"
title = "Fixed setpoints"
spec = "fictional"
unit = "Hz"
subcodes = 2

[[code]]
number = 40
name = "controller_inhibit"
role = "control-word"
title = "Controller inhibit"
spec = "fictional"
default = "0"
stopped = [0]

[[code]]
number = 46
name = "frequency_setpoint"
role = "setpoint"
title = "Frequency setpoint"
spec = "fictional"
unit = "Hz"

[[code]]
number = 50
name = "output_frequency"
title = "Output frequency"
spec = "fictional"
unit = "Hz"
access = "ro"

[[code]]
number = 94
name = "user_password"
title = "User password"
spec = "fictional"
role = "password"

[[code]]
number = 135
name = "control_word"
role = "control-word"
title = "Control word"
spec = "fictional"
type = "VH"
width = 2
[[code.bits]]
name = "quick_stop"
bits = [3, 3]
role = "inhibit"
[[code.bits]]
name = "controller_inhibit"
bits = [9, 9]
role = "inhibit"

[[code]]
number = 200
name = "unknown_type_code"
title = "A code without a usable type"
spec = "fictional"
type = "NOPE"
"#;

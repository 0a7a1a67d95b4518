function dynval_port()
%DYNVAL_PORT The dynval MATLAB port as a program of the conformance protocol (golden/PROTOCOL.md).
%   Reads cases on standard input and answers on standard output, computing every case with
%   the +dynval package:
%
%     octave-cli --no-gui --norc --quiet --eval "addpath('matlab'); dynval_port()"
%
%   matlab/run-port does exactly this. It needs GNU Octave for fflush(stdout) (the runner waits
%   for every answer, and Octave buffers a piped stdout fully); the +dynval package itself is
%   plain MATLAB.
  operations = {'residuals', 'sse', 'rmse', 'max_abs_error', 'vaf', 'fit_percent', 'r2', ...
    'residual_mean', 'residual_variance', 'zero_mean_test', 'autocorrelation', 'confidence_band', ...
    'ljung_box', 'box_pierce', 'cross_correlation', 'information_criteria', 'criteria', 'aic', 'bic', ...
    'accumulate'};
  out = sprintf('dynval-port 1 dynval-matlab 1.0 (%s %s)\n', runtime_name(), version());
  for i = 1:numel(operations)
    out = [out sprintf('capability %s\n', operations{i})]; %#ok<AGROW>
  end
  out = [out sprintf('ready\n')];
  fprintf(1, '%s', out);
  fflush(stdout);
  kase = [];
  while true
    line = read_line();
    if ~ischar(line)
      break;
    end
    if ~isempty(line) && line(end) == sprintf('\r')
      line = line(1:end - 1);
    end
    [word, rest] = strtok(line);
    if isempty(word) || word(1) == '#'
      continue;
    end
    if strcmp(word, 'quit')
      break;
    elseif strcmp(word, 'end')
      reply = answer(kase);
      fprintf(1, '%s', reply);
      fflush(stdout);
      kase = [];
      continue;
    end
    try
      switch word
        case 'case'
          kase = parse_case(rest);
        case 'scalar'
          [name, value] = strtok(rest);
          kase.inputs.(name) = struct('kind', 'scalar', 'value', parse_value(strtrim(value)), 'dims', []);
        case 'array'
          [name, item] = parse_array(rest);
          kase.inputs.(name) = item;
        otherwise
          error('dvport:line', 'unknown line: %s', word);
      end
    catch err
      % Answered at the case's 'end' line, which the runner waits to send first.
      kase.unreadable = err.message;
    end
  end
end

% --------------------------------------------------------------------------- reading

function line = read_line()
  % One line of standard input without its newline, or -1 at the end of input.
  % Not fgetl(stdin): on a pipe, Octave 7's fgetl reads one character past the newline
  % before it returns, so it blocks on the 'end' line of a case, while the runner waits for
  % the answer (a deadlock). input('', 's') returns as soon as the line is complete.
  try
    line = input('', 's');
  catch
    line = -1;
  end
end

function kase = parse_case(rest)
  tokens = regexp(rest, '\S+', 'match');
  kase = struct('family', tokens{1}, 'tcid', tokens{2}, 'operation', tokens{3});
  kase.conventions = struct();
  kase.inputs = struct();
  for i = 4:numel(tokens)
    k = find(tokens{i} == '=', 1);
    kase.conventions.(tokens{i}(1:k - 1)) = parse_value(tokens{i}(k + 1:end));
  end
end

function [name, item] = parse_array(rest)
  [name, rest] = strtok(rest);
  [type, rest] = strtok(rest);
  [ndim_token, rest] = strtok(rest);
  ndim = str2double(ndim_token);
  dims = zeros(1, ndim);
  for i = 1:ndim
    [token, rest] = strtok(rest);
    dims(i) = str2double(token);
  end
  values = dvport.read_values(rest);
  if numel(values) ~= prod(dims)
    error('dvport:array', 'array %s: %d values for a shape of %d', name, numel(values), prod(dims));
  end
  if ndim == 0
    a = values(1);
  elseif ndim == 1
    a = values(:);
  else
    % Row-major (C order) values: reverse the dimensions, then the axes.
    a = permute(reshape(values, fliplr(dims)), ndim:-1:1);
  end
  if strcmp(type, 'bool')
    a = logical(a);
  end
  item = struct('kind', 'array', 'value', a, 'dims', dims);
end

function v = parse_value(token)
  % Typed values: none -> [], true/false -> logical, numbers -> double, "..." -> char,
  % [a,b] -> row vector (an empty list is zeros(1, 0), which is not None).
  if strcmp(token, 'none')
    v = [];
  elseif strcmp(token, 'true')
    v = true;
  elseif strcmp(token, 'false')
    v = false;
  elseif token(1) == '"'
    v = decode_string(token(2:end - 1));
  elseif token(1) == '['
    body = token(2:end - 1);
    if isempty(body)
      v = zeros(1, 0);
    else
      parts = strsplit(body, ',');
      items = cellfun(@parse_value, parts, 'UniformOutput', false);
      if all(cellfun(@(x) isnumeric(x) && isscalar(x), items))
        v = [items{:}];
      else
        v = items;
      end
    end
  else
    v = dvport.read_real(token);
  end
end

function s = decode_string(body)
  s = '';
  i = 1;
  while i <= numel(body)
    if body(i) == '%'
      s = [s char(hex2dec(body(i + 1:i + 2)))]; %#ok<AGROW>
      i = i + 3;
    else
      s = [s body(i)]; %#ok<AGROW>
      i = i + 1;
    end
  end
end

% --------------------------------------------------------------------------- answering

function reply = answer(kase)
  try
    if isempty(kase) || isfield(kase, 'unreadable')
      message = 'no case line before end';
      if isfield(kase, 'unreadable')
        message = kase.unreadable;
      end
      error('dvport:case', 'cannot read the case: %s', message);
    end
    outputs = compute(kase);
    reply = '';
    for i = 1:numel(outputs)
      o = outputs{i};
      reply = [reply write_result(o{1}, o{2}, o{3})]; %#ok<AGROW>
    end
    reply = [reply sprintf('end\n')];
  catch err
    if strncmp(err.identifier, 'dynval:', 7)
      kind = err.identifier(8:end);
    else
      kind = 'InternalError';
    end
    message = err.message;
    if strcmp(kind, 'InternalError') && ~isempty(err.stack)
      message = sprintf('%s (%s line %d)', message, err.stack(1).name, err.stack(1).line);
    end
    message = regexprep(message, '[^\x20-\x7e]', ' ');
    reply = sprintf('error %s %s\nend\n', kind, message);
  end
end

function line = write_result(name, value, dims)
  % Values row-major, written by dvport.format_values (%.16e, or nan, inf, -inf).
  value = double(value);
  if numel(dims) >= 2
    value = permute(reshape(value, dims), numel(dims):-1:1);
  end
  line = sprintf('result %s real %d%s%s\n', name, numel(dims), sprintf(' %d', dims), ...
    dvport.format_values(value(:)));
end

function name = runtime_name()
  if exist('OCTAVE_VERSION', 'builtin')
    name = 'GNU Octave';
  else
    name = 'MATLAB';
  end
end

function v = input_value(kase, name)
  % An input of the case: the array, or the scalar value; [] when absent.
  if isfield(kase.inputs, name)
    item = kase.inputs.(name);
    v = item.value;
    if strcmp(item.kind, 'scalar') && isempty(v) && isnumeric(v) && any(strcmp(name, {'tau_meas', 'tau_pred', 'e', 'regressor'}))
      v = {};  % None as a data argument: not an array at all
    end
  else
    v = [];
  end
end

function d = declared_dims(kase, name)
  d = [];
  if isfield(kase.inputs, name) && strcmp(kase.inputs.(name).kind, 'array')
    d = kase.inputs.(name).dims;
  elseif isfield(kase.inputs, name) && isnumeric(kase.inputs.(name).value) && ~isempty(kase.inputs.(name).value)
    d = zeros(1, 0);  % a number given as data is a 0-d array
  end
end

function opts = options_of(kase, keys)
  % Name-value pairs of the case's conventions; a key the case does not set keeps its default.
  opts = {};
  for i = 1:numel(keys)
    if isfield(kase.conventions, keys{i})
      opts = [opts {keys{i}, kase.conventions.(keys{i})}]; %#ok<AGROW>
    end
  end
end

function one_d = is_one_d(kase, name)
  one_d = isfield(kase.inputs, name) && strcmp(kase.inputs.(name).kind, 'array') && numel(kase.inputs.(name).dims) == 1;
end

function outputs = compute(kase)
  op = kase.operation;
  c = kase.conventions;
  switch op
    case {'residuals', 'sse', 'rmse', 'max_abs_error', 'vaf', 'fit_percent', 'r2'}
      data = {input_value(kase, 'tau_meas'), input_value(kase, 'tau_pred')};
      precheck_signals(kase, {'tau_meas', 'tau_pred'});
      opts = options_of(kase, {'multioutput', 'convention', 'nan_policy'});
      value = feval(['dynval.' op], data{:}, opts{:});
      if strcmp(op, 'residuals')
        if is_one_d(kase, 'tau_meas') && is_one_d(kase, 'tau_pred')
          outputs = {{'value', value, numel(value)}};
        else
          outputs = {{'value', value, size(value)}};
        end
      elseif isfield(c, 'multioutput') && strcmp(c.multioutput, 'raw_values')
        outputs = {{'value', value, numel(value)}};
      else
        outputs = {{'value', value, []}};
      end
    case {'residual_mean', 'residual_variance'}
      e = input_value(kase, 'e');
      precheck_signals(kase, {'e'});
      opts = options_of(kase, {'ddof', 'nan_policy'});
      value = feval(['dynval.' op], e, opts{:});
      outputs = {{'value', value, numel(value)}};
    case 'zero_mean_test'
      e = input_value(kase, 'e');
      precheck_signals(kase, {'e'});
      opts = options_of(kase, {'segments', 'nan_policy'});
      r = dynval.zero_mean_test(e, opts{:});
      m = numel(r.mean);
      outputs = {{'mean', r.mean, m}, {'std', r.std, m}, {'n_samples', r.n_samples, []}, ...
        {'statistic_iid', r.statistic_iid, m}, {'pvalue_iid', r.pvalue_iid, m}, {'df_iid', r.df_iid, []}, ...
        {'statistic_eff', r.statistic_eff, m}, {'pvalue_eff', r.pvalue_eff, m}, {'df_eff', r.df_eff, m}, ...
        {'n_eff', r.n_eff, m}, {'bandwidth', r.bandwidth, []}};
    case 'autocorrelation'
      e = input_value(kase, 'e');
      precheck_signals(kase, {'e'});
      opts = options_of(kase, {'adjusted', 'segments', 'nan_policy'});
      rho = dynval.autocorrelation(e, input_value(kase, 'max_lag'), opts{:});
      if is_one_d(kase, 'e')
        outputs = {{'value', rho, numel(rho)}};
      else
        outputs = {{'value', rho, size(rho)}};
      end
    case 'confidence_band'
      opts = options_of(kase, {'level'});
      band = dynval.confidence_band(input_value(kase, 'n'), opts{:});
      outputs = {{'value', band, []}};
    case {'ljung_box', 'box_pierce'}
      e = input_value(kase, 'e');
      precheck_signals(kase, {'e'});
      opts = options_of(kase, {'model_df', 'segments', 'nan_policy'});
      r = feval(['dynval.' op], e, input_value(kase, 'lags'), opts{:});
      k = numel(r.lags);
      m = size(r.statistic, 2);
      outputs = {{'lags', r.lags, k}, {'statistic', r.statistic, [k m]}, {'pvalue', r.pvalue, [k m]}, ...
        {'log_pvalue', r.log_pvalue, [k m]}, {'df', r.df, k}};
    case 'cross_correlation'
      [e, Y, n_joints] = regressor_inputs(kase);
      opts = options_of(kase, {'adjusted', 'level', 'segments', 'nan_policy'});
      if ~isempty(n_joints)
        opts = [opts {'n_joints', n_joints}];
      end
      r = dynval.cross_correlation(e, Y, input_value(kase, 'max_lag'), opts{:});
      [m, p, ~] = size(r.rho);
      lags = size(r.rho, 3);
      outputs = {{'rho', r.rho, [m p lags]}, {'constant_mask', r.constant_mask, [m p]}, {'band', r.band, []}};
    case 'information_criteria'
      ic = dynval.information_criteria(input_value(kase, 'rss'), input_value(kase, 'n_obs'), input_value(kase, 'n_params'));
      outputs = {{'aic', ic.aic, []}, {'bic', ic.bic, []}, {'aicc', ic.aicc, []}, {'fpe', ic.fpe, []}, {'naic', ic.naic, []}};
    case {'criteria', 'aic', 'bic'}
      data = {input_value(kase, 'tau_meas'), input_value(kase, 'tau_pred')};
      precheck_signals(kase, {'tau_meas', 'tau_pred'});
      opts = options_of(kase, {'noise_model', 'nan_policy'});
      if strcmp(op, 'criteria')
        ic = dynval.criteria(data{:}, input_value(kase, 'n_params'), opts{:});
        outputs = {{'aic', ic.aic, []}, {'bic', ic.bic, []}, {'aicc', ic.aicc, []}, {'fpe', ic.fpe, []}, ...
          {'naic', ic.naic, []}, {'n_obs', ic.n_obs, []}};
      else
        outputs = {{'value', feval(['dynval.' op], data{:}, input_value(kase, 'n_params'), opts{:}), []}};
      end
    case 'accumulate'
      precheck_signals(kase, {'tau_meas', 'tau_pred'});
      args = {input_value(kase, 'tau_meas'), input_value(kase, 'tau_pred'), input_value(kase, 'n_params'), ...
        input_value(kase, 'max_lag'), c};
      if isfield(kase.inputs, 'regressor')
        args = [args, {input_value(kase, 'regressor'), declared_dims(kase, 'regressor')}];
      end
      r = dvport.accumulate(args{:});
      m = numel(r.sse);
      outputs = {{'sse', r.sse, m}, {'rmse', r.rmse, m}, {'max_abs_error', r.max_abs_error, m}, ...
        {'vaf', r.vaf, m}, {'fit_percent', r.fit_percent, m}, {'r2', r.r2, m}, ...
        {'residual_mean', r.residual_mean, m}, {'residual_variance', r.residual_variance, m}, ...
        {'autocorrelation', r.autocorrelation, size(r.autocorrelation)}};
      if ~isempty(r.rho)
        outputs{end + 1} = {'rho', r.rho, [m, numel(r.rho) / (m * size(r.autocorrelation, 1)), size(r.autocorrelation, 1)]};
      end
      ic = r.criteria;
      outputs = [outputs, {{'aic', ic.aic, []}, {'bic', ic.bic, []}, {'aicc', ic.aicc, []}, {'fpe', ic.fpe, []}, ...
        {'naic', ic.naic, []}}];
    otherwise
      error('dvport:operation', 'unknown operation %s', op);
  end
end

% --------------------------------------------------------------------------- declared shapes
% MATLAB arrays have no 0-d or 1-d form and drop trailing singleton dimensions, so a few
% shape rules of the contract depend on the shape the case declared rather than on the array.

function ok = all_arrays(kase, names)
  ok = true;
  for i = 1:numel(names)
    v = input_value(kase, names{i});
    ok = ok && (isnumeric(v) || islogical(v)) && isreal(v);
  end
end

function precheck_signals(kase, names)
  % A 0-d array fails the shape step at its place in the argument order.
  if ~all_arrays(kase, names)
    return;  % the type step comes first: the library raises it
  end
  for i = 1:numel(names)
    d = declared_dims(kase, names{i});
    if isempty(d) && ~isfield(kase.inputs, names{i})
      return;
    end
    if numel(d) == 0
      dynval.internal.raise('InvalidShape', sprintf('%s must be 1-D (N,) or 2-D (N, m), got shape ()', names{i}));
    end
    if numel(d) > 2 && ndims(input_value(kase, names{i})) == 2
      % (N, m, 1) arrives as an N-by-m matrix, which the library would take for a signal.
      dynval.internal.raise('InvalidShape', sprintf('%s must be 1-D (N,) or 2-D (N, m), got shape %s', ...
        names{i}, dynval.internal.format_shape(d)));
    end
    if numel(d) > 2 || (numel(d) == 2 && d(2) == 0)
      return;  % the library rejects this one, in order
    end
  end
end

function [e, Y, n_joints] = regressor_inputs(kase)
  e = input_value(kase, 'e');
  Y = input_value(kase, 'regressor');
  n_joints = input_value(kase, 'n_joints');
  if ~all_arrays(kase, {'e', 'regressor'})
    return;
  end
  precheck_signals(kase, {'e'});
  de = declared_dims(kase, 'e');
  if numel(de) > 2 || (numel(de) == 2 && de(2) == 0)
    return;
  end
  dy = declared_dims(kase, 'regressor');
  shape = python_shape(dy);
  if numel(dy) == 3 || numel(dy) == 2 && ~isempty(n_joints)
    if numel(dy) == 3 && dy(3) == 1
      n = size(e, 1);
      m = size(e, 2);
      if dy(1) ~= n || dy(2) ~= m
        dynval.internal.raise('ShapeMismatch', sprintf( ...
          'regressor must have shape (N, m, p) = (%d, %d, p) to match e, got %s', n, m, shape));
      end
      if ~isempty(n_joints)
        % N-by-m-by-1 is an N-by-m matrix in MATLAB, which the library would read as the
        % stacked form with n_joints: pass that form explicitly, it holds the same values.
        Y = reshape(Y.', n * m, 1);
      end
    end
    return;
  end
  dynval.internal.raise('InvalidShape', sprintf( ...
    'regressor must be 3-D (N, m, p) or 2-D (N*m, p) with n_joints, got shape %s', shape));
end

function s = python_shape(d)
  if isempty(d)
    s = '()';
  else
    s = dynval.internal.format_shape(d);
  end
end

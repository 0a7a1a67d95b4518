function failed = run_tests()
%RUN_TESTS Run every %!test block of the port (GNU Octave's test runner); returns the failures.
%   octave-cli --no-gui --norc --quiet --eval "cd matlab; exit(min(run_tests(), 1))"
%   matlab/run-tests does this and exits non-zero when a test fails.
  here = fileparts(mfilename('fullpath'));
  addpath(here);
  folders = {'+dynval', fullfile('+dynval', '+internal'), '+dvport'};
  failed = 0;
  total = 0;
  for i = 1:numel(folders)
    files = dir(fullfile(here, folders{i}, '*.m'));
    for j = 1:numel(files)
      path = fullfile(here, folders{i}, files(j).name);
      if isempty(strfind(fileread(path), '%!'))
        continue;
      end
      [passed, count] = test(path, 'quiet', stdout);
      if count > 0
        fprintf('%-45s %3d/%3d\n', fullfile(folders{i}, files(j).name), passed, count);
      end
      failed = failed + (count - passed);
      total = total + count;
    end
  end
  fprintf('%d tests, %d passed, %d failed\n', total, total - failed, failed);
end
